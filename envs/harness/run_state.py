"""Where a training run stands, as its checkpoint stores it: one declaration of the run state's
entries, with the checks each must pass alone and against the run's configuration and its map,
from which :meth:`RunState.to_entries` (the writer) and :meth:`RunState.from_entries` (the
reader) work. Any entry that fails is a :class:`~learners.persistence.CheckpointError` naming
it, raised before a resumed run writes anything."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

from learners.persistence import CheckpointError

#: trials between checkpoints of a run whose checkpoint does not store its interval (written
#: before runs kept it; the interval train.py has always defaulted to)
CHECKPOINT_EVERY = 1000
#: The running errors of the progress bar (mm), NaN before the first trial that measured them.
RUNNING_KEYS = ("coarse_mm", "fine_mm")
#: mm: no error of an arm of these robots' reach (about 1 m) comes near this (100 m).
MAX_ERROR_MM = 1e5
#: The env generator's state as numpy's PCG64 gives it (``bit_generator.state``).
RNG_KEYS = ("bit_generator", "has_uint32", "state", "uinteger")
RNG_KIND = "PCG64"
RNG_STATE_KEYS = ("inc", "state")
#: PCG64's state and increment are 128-bit, its buffered output 32-bit.
RNG_STATE_BITS, RNG_UINTEGER_BITS = 128, 32
#: Characters of a damaged value shown in a message.
SHOWN_CHARS = 30


def shown(value: Any) -> str:
    """``repr(value)``, cut to SHOWN_CHARS characters (a message stays one short line)."""
    text = repr(value)
    return text if len(text) <= SHOWN_CHARS else text[: SHOWN_CHARS - 3] + "..."


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _count(name: str, value: Any, least: int) -> str | None:
    """Why ``value`` is not an integer >= ``least`` (None if it is)."""
    if not _is_int(value) or value < least:
        return f"{name} is {shown(value)}, not an integer >= {least}"
    return None


def _flag(name: str, value: Any) -> str | None:
    return None if isinstance(value, bool) else f"{name} is {shown(value)}, not true or false"


def _running(name: str, value: Any) -> str | None:
    if not isinstance(value, Mapping) or sorted(value) != sorted(RUNNING_KEYS):
        return f"{name} is {shown(value)}, not {{{', '.join(RUNNING_KEYS)}}}"
    for key in RUNNING_KEYS:
        x = value[key]
        if not isinstance(x, float) or not (math.isnan(x) or 0.0 <= x <= MAX_ERROR_MM):
            return f"{name}[{key!r}] is {shown(x)}, not NaN or a float in 0 .. {MAX_ERROR_MM:g} mm"
    return None


def _rng(name: str, value: Any) -> str | None:
    if not isinstance(value, Mapping) or sorted(value) != sorted(RNG_KEYS):
        return f"{name} is {shown(value)}, not a generator state with {', '.join(RNG_KEYS)}"
    if value["bit_generator"] != RNG_KIND:
        return f"{name}['bit_generator'] is {shown(value['bit_generator'])}, not {RNG_KIND!r}"
    state = value["state"]
    if not isinstance(state, Mapping) or sorted(state) != sorted(RNG_STATE_KEYS):
        return f"{name}['state'] is {shown(state)}, not {{{', '.join(RNG_STATE_KEYS)}}}"
    for key in RNG_STATE_KEYS:
        if not _is_int(state[key]) or not 0 <= state[key] < 2**RNG_STATE_BITS:
            why = f"not a {RNG_STATE_BITS}-bit integer"
            return f"{name}['state'][{key!r}] is {shown(state[key])}, {why}"
    if state["inc"] % 2 == 0:  # PCG64 keeps its increment odd
        return f"{name}['state']['inc'] is even; PCG64's increment is odd"
    if value["has_uint32"] not in (0, 1) or not _is_int(value["has_uint32"]):
        return f"{name}['has_uint32'] is {shown(value['has_uint32'])}, not 0 or 1"
    if not _is_int(value["uinteger"]) or not 0 <= value["uinteger"] < 2**RNG_UINTEGER_BITS:
        return f"{name}['uinteger'] is {shown(value['uinteger'])}, not a 32-bit integer"
    return None


def _check(test: Any, default: Any = None) -> Any:
    """A field whose stored entry must pass ``test(name, value)`` (None, or why it does not);
    a field with a ``default`` may be missing from checkpoints written before it existed."""
    metadata = {"check": test}
    if default is None:
        return field(metadata=metadata)
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class RunState:
    """Where a training run stands: its checkpoint's entries besides the configuration and the
    identity (``Trainer.save`` writes :meth:`to_entries`, ``Trainer.resume`` reads
    :meth:`from_entries` and :meth:`check_fits`).

    Attributes:
        trial: trials done (0 .. the run's trials, at least the map's learned trials ``t``).
        running: the progress bar's running errors, ``RUNNING_KEYS`` (mm; NaN before any).
        metrics_rows: rows of ``metrics.jsonl`` that belong to the checkpoint: one held-out
            evaluation at trial 0 and every ``eval_every`` trials up to ``trial`` (the one at
            ``trial`` unless ``pending_eval``), and at the ends of the run's earlier extents.
        pending_eval: the held-out evaluation at ``trial`` is still to be done.
        env_rng: the training env's generator state (numpy's PCG64 ``bit_generator.state``).
        checkpoint_every: trials between checkpoints (``train.py --checkpoint-every``).
    """

    trial: int = _check(lambda n, v: _count(n, v, 0))
    running: Mapping[str, float] = _check(_running)
    metrics_rows: int = _check(lambda n, v: _count(n, v, 0))
    pending_eval: bool = _check(_flag)
    env_rng: Mapping[str, Any] = _check(_rng)
    checkpoint_every: int = _check(lambda n, v: _count(n, v, 1), CHECKPOINT_EVERY)

    def __post_init__(self) -> None:
        """Each field checked alone; CheckpointError naming the first that fails."""
        for f in fields(self):
            why = f.metadata["check"](f.name, getattr(self, f.name))
            if why is not None:
                raise CheckpointError(f"the run state's {why}")
        if self.trial == 0 and not all(math.isnan(self.running[k]) for k in RUNNING_KEYS):
            raise CheckpointError(
                f"the run state's running is {shown(dict(self.running))} at trial 0, where no "
                "error has been measured (NaN)"
            )

    @classmethod
    def from_entries(cls, entries: Mapping[str, Any], where: str) -> RunState:
        """The run state of a checkpoint's run entries (other entries are left to their
        readers); CheckpointError naming ``where`` and the entry that is missing or wrong."""
        wanted = {}
        for f in fields(cls):
            if f.name in entries:
                wanted[f.name] = entries[f.name]
            elif f.default is not MISSING:  # added later: older checkpoints lack it
                continue
            else:
                raise CheckpointError(f"{where}: the run state lacks {f.name}; the file is damaged")
        try:
            return cls(**wanted)
        except CheckpointError as exc:
            raise CheckpointError(f"{where}: {exc}; the file is damaged") from None

    def to_entries(self) -> dict[str, Any]:
        """The entries a checkpoint stores (JSON-able; :meth:`from_entries` reads them)."""
        return {f.name: _plain(getattr(self, f.name)) for f in fields(self)}

    def check_fits(self, where: str, trials: int, eval_every: int, learned: int) -> None:
        """The state against the run: ``trial`` within its ``trials`` and not below the map's
        ``learned`` trials (one learning step per trial at most), ``metrics_rows`` at least the
        evaluations of its schedule (trial 0 and every ``eval_every`` trials) done by ``trial``
        and at most one per trial.
        CheckpointError naming ``where`` and the entries that disagree."""
        if self.trial > trials:
            self._refuse(where, f"trial is {shown(self.trial)}, beyond the run's {trials} trials")
        if learned > self.trial:
            why = f"below the map's {learned} learned trials (t)"
            self._refuse(where, f"trial is {self.trial}, {why}")
        scheduled = -(-self.trial // eval_every)  # trial 0, eval_every, ... below trial
        scheduled += self.trial % eval_every == 0 and not self.pending_eval
        if self.metrics_rows > self.trial + 1:  # rows of distinct trials 0 .. trial
            self._refuse(where, f"metrics_rows is {shown(self.metrics_rows)}, beyond one row per "
                         f"trial 0 .. {self.trial}")  # fmt: skip
        if self.metrics_rows < scheduled:
            self._refuse(
                where,
                f"metrics_rows is {self.metrics_rows}, but {scheduled} held-out evaluations "
                f"(every {eval_every} trials) were done by trial {self.trial}"
                f"{' (pending_eval: its own still to do)' if self.pending_eval else ''}",
            )

    @staticmethod
    def _refuse(where: str, why: str) -> None:
        raise CheckpointError(f"{where}: the run state's {why}; the file is damaged")


def _plain(value: Any) -> Any:
    """``value`` with its mappings as plain dicts (what ``json.dumps`` writes)."""
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    return value
