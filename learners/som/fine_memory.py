"""What the visuomotor map remembers between the moves of one trial (the fine-move memory).

A coarse move starts it (the target u, the command sent, the Ā of the fine moves); each fine
move records the position v it corrected from and the command before it, which the next fine
move's Broyden step uses; with ``recover`` it also keeps the last command whose marker both
cameras saw, and where. A checkpoint stores it, so that a trial continues bit-identically.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from learners.guards import InputBox
from learners.som import stored

#: The fields of the memory in a checkpoint: the names the first files gave them.
_STORED = {
    "u": "_u", "cmd": "_cmd", "abar": "_abar", "v": "_v", "cmd_before": "_cmd_before",
    "seen_cmd": "_seen_cmd", "seen_v": "_seen_v",
}  # fmt: skip
#: The fields that hold joint commands (the others: positions in input space, and Ā).
_COMMANDS = ("cmd", "cmd_before", "seen_cmd")


@dataclass(eq=False)
class FineMemory:
    """The fine-move memory of one trial; every field None until a move sets it.

    Attributes:
        u: (D,) target of the current moves.
        cmd: (J,) last command.
        abar: (J, D) Ā of the fine moves.
        v: (D,) position sensed before the last fine command.
        cmd_before: (J,) command before the last fine one.
        seen_cmd, seen_v: with ``recover``: the last command whose marker both cameras saw
            (J,), and where (D,).
    """

    u: np.ndarray | None = None
    cmd: np.ndarray | None = None
    abar: np.ndarray | None = None
    v: np.ndarray | None = None
    cmd_before: np.ndarray | None = None
    seen_cmd: np.ndarray | None = None
    seen_v: np.ndarray | None = None

    def take(self, other: FineMemory) -> None:
        """Hold what ``other`` holds (the same arrays): this object stays the one the map and
        its compiled path share."""
        for f in fields(self):
            setattr(self, f.name, getattr(other, f.name))

    def start(self, u: np.ndarray, cmd: np.ndarray, abar: np.ndarray) -> None:
        """A coarse move for target u sent ``cmd`` and gives the fine moves ``abar`` (the
        arrays are kept, not copied)."""
        self.u, self.cmd, self.abar = u, cmd, abar
        self.v = self.cmd_before = None

    def after_fine(self, v: np.ndarray, cmd: np.ndarray) -> None:
        """A fine move corrected from v (copied) and sent ``cmd``."""
        self.v, self.cmd_before = v.copy(), self.cmd
        self.cmd = cmd

    def forget_seen(self) -> None:
        self.seen_cmd = self.seen_v = None

    def remember_seen(self, v: np.ndarray, input_dim: int) -> None:
        """Before a fine move from v: if both cameras saw the marker (v finite), the last
        command and v are the last pose seen in this trial."""
        v = np.asarray(v, dtype=float)
        if self.cmd is not None and v.shape == (input_dim,) and np.isfinite(v).all():
            self.seen_cmd, self.seen_v = self.cmd.copy(), v.copy()

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The fields that are set, as a checkpoint stores them (copies: the compiled path
        writes the memory in place)."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if value is not None:
                out[_STORED[f.name]] = value.copy()
        return out

    @classmethod
    def from_arrays(
        cls, arrays: dict[str, np.ndarray], lower: np.ndarray, upper: np.ndarray, inputs: InputBox
    ) -> FineMemory:
        """The memory a checkpoint stored for a map of joint ranges [lower, upper] (J,) and
        input box ``inputs`` (D,) (copies): what the moves could have left there, positions in
        the margin around the box, commands in the joint ranges (every command is clipped), Ā
        within the limit of the map's A (``learners.som.stored``).

        Raises:
            ValueError: a stored field of another shape or dtype, not finite, or out of range.
        """
        J, D = len(lower), len(inputs.low)
        shapes = {"u": (D,), "cmd": (J,), "abar": (J, D), "v": (D,), "cmd_before": (J,),
                  "seen_cmd": (J,), "seen_v": (D,)}  # fmt: skip
        memory = cls()
        for name, key in _STORED.items():
            if key not in arrays:
                continue
            value = stored.array(arrays, key, shapes[name])
            if name in _COMMANDS:
                stored.within(key, value, lower, upper, "the joint ranges")
            elif name == "abar":
                stored.check_linear_map(key, value, upper - lower, inputs.high - inputs.low)
            elif not inputs.inside(value):
                raise ValueError(f"array {key!r} lies beyond the margin around the {inputs.what}")
            setattr(memory, name, value.copy())
        return memory
