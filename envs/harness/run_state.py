"""Where a training run stands, as its checkpoint stores it: one declaration of the run state's
entries, with the checks each must pass alone and against the run's configuration and its map,
from which :meth:`RunState.to_entries` (the writer) and :meth:`RunState.from_entries` (the
reader) work. Any entry that fails is a :class:`~learners.persistence.CheckpointError` naming
it, raised before a resumed run writes anything."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

from learners.persistence import CheckpointError, quoted
from learners.som import stored

#: trials between checkpoints of a run whose checkpoint does not store its interval (written
#: before runs kept it; the interval train.py has always defaulted to)
CHECKPOINT_EVERY = 1000
#: The running errors of the progress bar (mm), NaN before the first trial that measured them.
RUNNING_KEYS = ("coarse_mm", "fine_mm")
#: mm: no error of an arm of these robots' reach (about 1 m) comes near this (100 m).
MAX_ERROR_MM = 1e5
#: Characters of a damaged value shown in a message.
SHOWN_CHARS = 30


def shown(value: Any) -> str:
    """``repr(value)``, cut to SHOWN_CHARS characters (a message stays one short line)."""
    return quoted(repr(value), SHOWN_CHARS)


def _count(least: int) -> Callable[[str, Any], None]:
    """The check of a count >= ``least`` (:func:`learners.som.stored.count`)."""

    def check(name: str, value: Any) -> None:
        stored.count(name, value, least)

    return check


def _flag(name: str, value: Any) -> None:
    if not isinstance(value, bool):
        raise ValueError(f"{name} is {shown(value)}, not true or false")


def _running(name: str, value: Any) -> None:
    if not isinstance(value, Mapping) or sorted(value) != sorted(RUNNING_KEYS):
        raise ValueError(f"{name} is {shown(value)}, not {{{', '.join(RUNNING_KEYS)}}}")
    for key in RUNNING_KEYS:
        x = value[key]
        if not isinstance(x, float) or not (math.isnan(x) or 0.0 <= x <= MAX_ERROR_MM):
            why = f"not NaN or a float in 0 .. {MAX_ERROR_MM:g} mm"
            raise ValueError(f"{name}[{key!r}] is {shown(x)}, {why}")


def _rng(name: str, value: Any) -> None:
    """The state of the env's generator (:func:`learners.som.stored.generator`, the map's)."""
    stored.generator(value, name)


def _check(test: Any, default: Any = None) -> Any:
    """A field whose stored entry must pass ``test(name, value)`` (ValueError saying why not);
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

    trial: int = _check(_count(0))
    running: Mapping[str, float] = _check(_running)
    metrics_rows: int = _check(_count(0))
    pending_eval: bool = _check(_flag)
    env_rng: Mapping[str, Any] = _check(_rng)
    checkpoint_every: int = _check(_count(1), CHECKPOINT_EVERY)

    def __post_init__(self) -> None:
        """Each field checked alone; CheckpointError naming the first that fails."""
        for f in fields(self):
            try:
                f.metadata["check"](f.name, getattr(self, f.name))
            except ValueError as exc:
                raise CheckpointError(f"the run state's {exc}") from None
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
