"""The options of the visuomotor map, in one frozen dataclass.

:class:`SOMConfig` is the only list of the map's options. Each field is declared once, with its
metadata (help, choices, whether a training run exposes it, how files written before it existed
read: ``learners/som/options.py``); the checkpoint entries (:meth:`SOMConfig.to_dict`,
:meth:`SOMConfig.from_dict`), the map's read-only option attributes, a training run's options
(:func:`run_options`) and the command-line choices are generated from the fields. What each
option does is on ``docs/map.md``.

The compute kernel (numba or numpy) is not an option of the map: both give the same moves (the
compiled path is checked against the numpy reference), so it is chosen where the map is built
or loaded and is not stored with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any, TypeVar

from learners.som.options import (
    OPTION_LIMIT,
    check_common,
    entries,
    from_entries,
    number,
    option,
    positive_shape,
    run_options,
    schedule_names,
)
from learners.som.schedules import Continual, Schedule, harmonic

__all__ = [
    "ABAR", "AVERAGING", "MAX_NEURONS", "NOISE_SKIP", "NOISE_TERMS", "PROTOCOLS", "RULES",
    "SCHEDULES", "SHAPE_OPTIONS", "THETA_TARGETS", "SOMConfig", "run_options",
]  # fmt: skip

AVERAGING = ("neighbourhood", "winner")
#: Ā of the fine moves: MRS's σ'-average of the A_r, or this project's local fit at u.
ABAR = ("average", "local-fit")
#: How the map moves and learns: "mrs", the loop of Ritter, Martinetz & Schulten with this
#: project's additions (a fine move corrects from what was sensed), or "brause", Brause's own
#: (coarse Θ_c, fine (3.7), which does not use what was sensed; docs/map.md).
PROTOCOLS = ("mrs", "brause")
#: Options fixed by the shape of the learned arrays: a learned map cannot change them.
SHAPE_OPTIONS = ("lattice", "input_dim")
#: Neurons a lattice may have: 10^7 neurons of 4 inputs and 6 joints hold about 2.7 GB.
MAX_NEURONS = 10_000_000

# Schedules x_i -> x_f over t_max trials (σ in lattice units); docs/decisions.md, "The map",
# says where the values come from.
DEFAULT_EPS = Schedule(1.0, 0.005)
DEFAULT_SIGMA = Schedule(2.0, 0.1)
DEFAULT_EPS_OUT = Schedule(0.9, 0.1)
DEFAULT_SIGMA_OUT = Schedule(2.5, 0.01)
#: Exploration std of training fine moves, rad (this project's choice).
DEFAULT_EXPLORE = Schedule(0.05, 0.005)
#: Brause's single rate γ (protocol "brause"), harmonic from 1 to 0.1 at t_max (this project's
#: choice; he gives no values).
DEFAULT_GAMMA = Schedule(1.0, 0.1)
DEFAULT_T_MAX = 10_000
#: Trials with |Δv| below this (input units, e.g. pixels) are skipped: the Widrow-Hoff step
#: divides by |Δv|², and a sensed displacement this small is below any detector's resolution.
DEFAULT_MIN_DV = 1e-3
#: Std of a sensed input coordinate's error that the Widrow-Hoff step of A corrects for (input
#: units): 0 is the published step.
DEFAULT_SENSING_NOISE = 0.0
#: Sightings whose errors enter a trial's Widrow-Hoff step in the mean (e1 once, e0 twice: in
#: the sensed Δv and, through the fine move that corrected it, in Δθ): the 3 of 3σ².
NOISE_TERMS = 3
#: With ``sensing_noise`` σ on, trials with |Δv| below this many σ are skipped too: the
#: correction 3σ²/|Δv|² then stays below 0.12 (smaller Δv made it diverge; docs/decisions.md).
NOISE_SKIP = 5
#: Std of the initial A_r entries as a fraction of mean joint span / mean input span.
DEFAULT_A_INIT = 0.1
#: ... at most this: a thousand joint spans per input span is far from any map that reaches.
MAX_A_INIT = 1e3
#: Inputs a map may have (4 for two cameras' pixels); more is damage or a typing error.
MAX_INPUT_DIM = 1000
#: Trials a schedule may run over: 2^53, every count up to it exact as a float.
MAX_T_MAX = 2**53

#: The θ* the outputs learn towards (``theta_target``): the error sensed after the coarse move
#: (θ_s + A_s(u − v0), MRS) or after the fine move (θ1 + A_s(w_s − v1), Brause 3.9).
THETA_TARGETS = ("coarse-error", "fine-error")
#: ... as a checkpoint stores them, under the option's first name ``rule`` (files keep their
#: bytes; ``SOMConfig.of(rule=...)`` still takes these for callers written before the rename).
RULES = ("mrs", "brause")
_STORED_TARGETS = dict(zip(THETA_TARGETS, RULES, strict=True))
#: The option's old name and how its values read now.
RENAMED = {"rule": ("theta_target", {v: k for k, v in _STORED_TARGETS.items()})}
_OWNER = "SOMConfig"


C = TypeVar("C", bound=type)


def _refuse_renamed(cls: C) -> C:
    """``cls(rule=...)`` is a ValueError naming the new option and its values."""
    generated = cls.__init__  # type: ignore[misc]  # the class's own, wrapped once here

    def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
        for old, (new, values) in RENAMED.items():
            if old in kwargs:
                spelled = ", ".join(f"{n!r} (was {o!r})" for o, n in values.items())
                raise ValueError(f"SOMConfig has no option {old!r}: it is {new!r} = {spelled}")
        generated(self, *args, **kwargs)

    __init__.__doc__, __init__.__wrapped__ = generated.__doc__, generated  # type: ignore[attr-defined]
    cls.__init__ = __init__  # type: ignore[misc]
    return cls


@_refuse_renamed
@dataclass(frozen=True)
class SOMConfig:
    """Every option of the visuomotor map (``docs/map.md`` says what each does). Values are
    checked on construction; schedules may be given as a
    :class:`~learners.som.schedules.Schedule`, an (initial, final) pair or one constant. Each
    field's metadata (``learners/som/options.py``) holds its one-line help, its choices, whether
    a training run exposes it, and how its checkpoint stores it.

    Raises:
        ValueError: an option of the wrong type, an unknown choice (the valid ones named), a
            size or count below its minimum, a schedule out of its range, or the old name
            ``rule`` (the error names ``theta_target``).
    """

    lattice: tuple[int, ...] = option(
        (12, 7, 4), "lattice shape, default 12x7x4 = 336 neurons (MRS 1990)", run=True
    )
    input_dim: int = option(4, "D: 4 for two cameras' pixels (u1, v1, u2, v2), 3 for Cartesian")
    theta_target: str = option(
        "coarse-error",
        "the theta* the outputs learn towards: the error sensed after the coarse move (MRS) "
        "or after the fine move (Brause 3.9)",
        choices=THETA_TARGETS, run=True, stored_as="rule", stored_values=_STORED_TARGETS,
    )  # fmt: skip
    averaging: str = option(
        "neighbourhood", "outputs averaged with width sigma', or the winner alone",
        choices=AVERAGING,
    )  # fmt: skip
    refine: bool = option(
        True, "correct the fine moves' A-bar between fine moves of one target (Broyden step)",
        run=True,
    )  # fmt: skip
    abar: str = option(
        "local-fit", "A-bar of the test-time fine moves: MRS's average or a local fit at u",
        choices=ABAR, run=True, added_later="local-fit",
    )  # fmt: skip
    t_max: int = option(
        DEFAULT_T_MAX, "trials over which the schedules fall from initial to final value"
    )
    eps: Schedule = option(DEFAULT_EPS, "epsilon(t) of the w update")  # noqa: RUF009 (a field)
    sigma: Schedule = option(DEFAULT_SIGMA, "sigma(t) of the w update, lattice units")  # noqa: RUF009 (a field)
    eps_out: Schedule = option(DEFAULT_EPS_OUT, "epsilon'(t) of the theta and A update")  # noqa: RUF009 (a field)
    sigma_out: Schedule = option(  # noqa: RUF009 (a field)
        DEFAULT_SIGMA_OUT, "sigma'(t) of the theta and A update and the output averaging"
    )
    explore: Schedule = option(  # noqa: RUF009 (a field)
        DEFAULT_EXPLORE, "std (rad) of the noise of exploratory (training) fine moves"
    )
    gamma: Schedule = option(  # noqa: RUF009 (a field)
        DEFAULT_GAMMA, "Brause's single rate for w, theta and A (protocol brause, harmonic)",
        added_later=DEFAULT_GAMMA,
    )  # fmt: skip
    a_init: float = option(
        DEFAULT_A_INIT, "std of the random start of A, a fraction of joint span / input span"
    )
    min_dv: float = option(DEFAULT_MIN_DV, "trials with |v1 - v0| below this are skipped")
    protocol: str = option(
        "mrs", "the trial protocol: MRS's loop or Brause's own (3.7, 3.9, 3.10)",
        choices=PROTOCOLS, run=True, added_later="mrs",
    )  # fmt: skip
    continual: Continual | None = option(  # noqa: RUF009 (a field)
        None, "keep re-adapting after t_max when the sensed error rises (None: floors)",
        omit_default=True,
    )  # fmt: skip
    recover: bool = option(
        False, "after a move a camera did not see, make recovery moves instead of stopping",
        omit_default=True,
    )  # fmt: skip
    sensing_noise: float = option(
        DEFAULT_SENSING_NOISE,
        "sigma, std of a sensed input coordinate's error that the Widrow-Hoff step of A "
        "corrects for (input units; 0: the published step)",
        run=True, omit_default=True,
    )  # fmt: skip

    def __post_init__(self) -> None:
        check_common(self)
        lattice = positive_shape(_OWNER, "lattice", self.lattice)
        if not lattice:
            raise ValueError(
                f"SOMConfig.lattice must be a tuple of positive sizes, got {self.lattice!r}"
            )
        if math.prod(lattice) > MAX_NEURONS:
            raise ValueError(
                f"SOMConfig.lattice {lattice} has {math.prod(lattice):,} neurons; at most "
                f"{MAX_NEURONS:,} fit in memory (a 40x40x40 lattice has 64,000)"
            )
        object.__setattr__(self, "lattice", lattice)
        for name, kind, least, most in (
            ("input_dim", int, 1, MAX_INPUT_DIM), ("t_max", int, 1, MAX_T_MAX),
            ("a_init", float, 0, MAX_A_INIT), ("min_dv", float, 0, OPTION_LIMIT),
            ("sensing_noise", float, 0, OPTION_LIMIT),
        ):  # fmt: skip
            value = number(_OWNER, name, getattr(self, name), kind, least, most)
            object.__setattr__(self, name, value)
        harmonic(self.gamma.initial, self.gamma.final, 0, self.t_max)  # raises for a bad gamma
        if self.continual is not None and not isinstance(self.continual, Continual):
            raise ValueError(
                f"SOMConfig.continual must be a Continual or None, got {self.continual!r}"
            )

    @property
    def rule(self) -> str:
        """``theta_target`` by its old name and values ("mrs", "brause"), as files store it."""
        return _STORED_TARGETS[self.theta_target]

    @property
    def learn_min_dv(self) -> float:
        """Trials with |v1 − v0| below this are not learned: ``min_dv``, or ``NOISE_SKIP`` σ
        when that is larger (``sensing_noise``)."""
        return max(self.min_dv, NOISE_SKIP * self.sensing_noise)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The option names, in declaration order."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def of(cls, config: SOMConfig | None = None, **options: Any) -> SOMConfig:
        """``config`` (default: the defaults) with ``options`` changed; an unknown option name
        is a ValueError listing the valid ones. The old name ``rule`` ("mrs", "brause") is read
        as ``theta_target``."""
        for old, (new, values) in RENAMED.items():
            if old in options:
                value = options.pop(old)
                if value not in values:
                    raise ValueError(f"unknown {old} {value!r}; valid: {', '.join(values)}")
                options.setdefault(new, values[value])
        unknown = sorted(set(options) - set(cls.names()))
        if unknown:
            raise ValueError(
                f"unknown map option(s) {', '.join(unknown)}; valid: {', '.join(cls.names())}"
            )
        return replace(config or cls(), **options)

    def to_dict(self) -> dict[str, Any]:
        """The options as JSON-ready entries, as the map's checkpoint stores them
        (``learners.som.options.entries``: ``theta_target`` as ``rule`` = "mrs" or "brause",
        ``continual``, ``recover`` and ``sensing_noise`` absent while default)."""
        return entries(self)

    @classmethod
    def from_dict(cls, stored: dict[str, Any]) -> SOMConfig:
        """The configuration stored by :meth:`to_dict` (other entries are ignored).

        Entries added in later releases may be missing (``abar``, ``protocol``, the ``gamma``
        schedule): they take the value maps had before (each field's ``added_later``). Raises
        ValueError naming the entry that is missing or of the wrong type or value (a damaged or
        foreign file).
        """
        return from_entries(cls, stored)


#: The schedules of the map, in the order its checkpoint stores them.
SCHEDULES = schedule_names(SOMConfig)
