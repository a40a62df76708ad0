"""The options of the visuomotor map, in one frozen dataclass.

:class:`SOMConfig` is the only list of the map's options: the constructor of
:class:`~learners.som.controller.VisuomotorSOM` takes its fields by name, the map's option
attributes read it, its checkpoint stores :meth:`SOMConfig.to_dict` and reads it back with
:meth:`SOMConfig.from_dict`, and the command-line programs take their choices (``PROTOCOLS``,
``ABAR``, ...) from here. The meaning of every option is in the map's module docstring.

The compute kernel (numba or numpy) is not an option of the map: both give the same moves (the
compiled path is checked against the numpy reference), so it is chosen where the map is built
or loaded and is not stored with it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from learners.base import PROTOCOLS
from learners.guards import option_number
from learners.som.schedules import Continual, Schedule, harmonic

RULES = ("mrs", "brause")
AVERAGING = ("neighbourhood", "winner")
#: Ā of the fine moves: MRS's σ'-average of the A_r, or this project's local fit at u.
ABAR = ("average", "local-fit")
#: The schedules of the map, in the order its checkpoint stores them.
SCHEDULES = ("eps", "sigma", "eps_out", "sigma_out", "explore", "gamma")
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

_CHOICES = {"rule": RULES, "averaging": AVERAGING, "abar": ABAR, "protocol": PROTOCOLS}
#: Entries a checkpoint written before the option existed lacks: read as these values.
_ADDED_LATER = {"abar": "local-fit", "protocol": "mrs"}


def _number(name: str, value: Any, kind: type) -> Any:
    """``value`` as ``kind`` (int or float), else ValueError naming the option."""
    return option_number("SOMConfig", name, value, kind)


@dataclass(frozen=True)
class SOMConfig:
    """Every option of the visuomotor map (see ``learners/som/controller.py`` for what each
    does). Values are checked on construction; schedules may be given as a
    :class:`~learners.som.schedules.Schedule`, an (initial, final) pair or one constant.

    Args:
        lattice: lattice shape, default (12, 7, 4) = 336 neurons (MRS 1990).
        input_dim: D, 4 for two cameras' pixels (u1, v1, u2, v2), 3 for Cartesian input.
        rule: one of ``RULES``: the θ* the outputs learn towards.
        averaging: one of ``AVERAGING``: outputs averaged with width σ', or the winner alone.
        refine: correct Ā between fine moves of one target (Broyden step).
        abar: one of ``ABAR``: Ā of the fine moves.
        t_max: trials over which the schedules fall from their initial to their final value.
        eps, sigma: ε(t) and σ(t) of the w update (σ in lattice units).
        eps_out, sigma_out: ε'(t), σ'(t) of the θ/A update and of the output averaging.
        explore: std (rad) of the noise of fine commands made with ``explore=True``.
        gamma: Brause's single rate for w, Θ and A under protocol "brause" (harmonic).
        a_init: std of the random start of A_r, as a fraction of mean joint span / mean input
            span (0 = start at A = 0).
        min_dv: trials with |v1 − v0| below this are skipped (input units).
        sensing_noise: σ, the std of the error of one sensed input coordinate (input units,
            e.g. pixels): the Widrow-Hoff step of A adds 3σ² A_s to its numerator, undoing the
            shrinking of A that noise in v0 and v1 causes (errors in variables; 0: the
            published step). Trials with |Δv| < ``NOISE_SKIP`` σ are then skipped (as below
            ``min_dv``). Protocol "mrs" only.
        protocol: one of ``PROTOCOLS``: MRS's loop or Brause's own.
        continual: a :class:`~learners.som.schedules.Continual` to keep re-adapting after t_max
            when the sensed error rises (None: the standard schedules, floors from t_max on).
        recover: when a camera loses the marker after a move, make recovery moves (a detour
            the map has learned, ``learners/som/recovery.py``) and go on, instead of stopping
            the trial (MRS's loop stops; not in the papers). Protocol "mrs" only.
    Raises:
        ValueError: an option of the wrong type, an unknown choice (the valid ones named), a
            size or count below its minimum, or a schedule out of its range.
    """

    lattice: tuple[int, ...] = (12, 7, 4)
    input_dim: int = 4
    rule: str = "mrs"
    averaging: str = "neighbourhood"
    refine: bool = True
    abar: str = "local-fit"
    t_max: int = DEFAULT_T_MAX
    eps: Schedule = DEFAULT_EPS
    sigma: Schedule = DEFAULT_SIGMA
    eps_out: Schedule = DEFAULT_EPS_OUT
    sigma_out: Schedule = DEFAULT_SIGMA_OUT
    explore: Schedule = DEFAULT_EXPLORE
    gamma: Schedule = DEFAULT_GAMMA
    a_init: float = DEFAULT_A_INIT
    min_dv: float = DEFAULT_MIN_DV
    sensing_noise: float = DEFAULT_SENSING_NOISE
    protocol: str = "mrs"
    continual: Continual | None = None
    recover: bool = False

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        for name, choices in _CHOICES.items():
            if getattr(self, name) not in choices:
                raise ValueError(
                    f"unknown {name} {getattr(self, name)!r}; valid: {', '.join(choices)}"
                )
        try:
            lattice = tuple(_number("lattice", n, int) for n in self.lattice)
        except TypeError:
            lattice = ()
        if not lattice or min(lattice) < 1:
            raise ValueError(f"SOMConfig.lattice must be a tuple of positive sizes, got {lattice}")
        if math.prod(lattice) > MAX_NEURONS:
            raise ValueError(
                f"SOMConfig.lattice {lattice} has {math.prod(lattice):,} neurons; at most "
                f"{MAX_NEURONS:,} fit in memory (a 40x40x40 lattice has 64,000)"
            )
        put("lattice", lattice)
        for name in ("refine", "recover"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(
                    f"SOMConfig.{name} must be True or False, got {getattr(self, name)!r}"
                )
        for name, kind, least in (
            ("input_dim", int, 1), ("t_max", int, 1), ("a_init", float, 0), ("min_dv", float, 0),
            ("sensing_noise", float, 0),
        ):  # fmt: skip
            value = _number(name, getattr(self, name), kind)
            if value < least:
                raise ValueError(f"SOMConfig.{name} must be >= {least}, got {value}")
            put(name, value)
        for name in SCHEDULES:
            put(name, self._schedule(name, getattr(self, name)))
        for name in ("eps", "eps_out"):
            if max(getattr(self, name).initial, getattr(self, name).final) > 1.0:
                raise ValueError(f"{name} is a learning rate in [0, 1], got {getattr(self, name)}")
        harmonic(self.gamma.initial, self.gamma.final, 0, self.t_max)  # raises for a bad gamma
        if self.continual is not None and not isinstance(self.continual, Continual):
            raise ValueError(
                f"SOMConfig.continual must be a Continual or None, got {self.continual!r}"
            )

    @property
    def learn_min_dv(self) -> float:
        """Trials with |v1 − v0| below this are not learned: ``min_dv``, or ``NOISE_SKIP`` σ
        when that is larger (``sensing_noise``)."""
        return max(self.min_dv, NOISE_SKIP * self.sensing_noise)

    @staticmethod
    def _schedule(name: str, value: Any) -> Schedule:
        try:
            schedule = Schedule.of(value)
        except ValueError as exc:
            raise ValueError(f"SOMConfig.{name}: {exc}") from None
        except TypeError:
            raise ValueError(
                f"SOMConfig.{name} must be a Schedule, an (initial, final) pair or a number, "
                f"got {value!r}"
            ) from None
        for end in (schedule.initial, schedule.final):
            _number(name, end, float)
        return schedule

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The option names, in declaration order."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def of(cls, config: SOMConfig | None = None, **options: Any) -> SOMConfig:
        """``config`` (default: the defaults) with ``options`` changed; an unknown option name
        is a ValueError listing the valid ones."""
        unknown = sorted(set(options) - set(cls.names()))
        if unknown:
            raise ValueError(
                f"unknown map option(s) {', '.join(unknown)}; valid: {', '.join(cls.names())}"
            )
        return replace(config or cls(), **options)

    def to_dict(self) -> dict[str, Any]:
        """The options as JSON-ready entries, as the map's checkpoint stores them."""
        out: dict[str, Any] = {
            "lattice": list(self.lattice),
            "input_dim": self.input_dim,
            "rule": self.rule,
            "averaging": self.averaging,
            "refine": self.refine,
            "abar": self.abar,
            "t_max": self.t_max,
            "schedules": {k: [getattr(self, k).initial, getattr(self, k).final] for k in SCHEDULES},
            "a_init": self.a_init,
            "min_dv": self.min_dv,
            "protocol": self.protocol,
        }
        if self.continual is not None:
            out["continual"] = asdict(self.continual)
        if self.recover:  # absent when off: maps without it keep their files
            out["recover"] = True
        if self.sensing_noise:  # absent when 0, as recover
            out["sensing_noise"] = self.sensing_noise
        return out

    @classmethod
    def from_dict(cls, entries: dict[str, Any]) -> SOMConfig:
        """The configuration stored by :meth:`to_dict` (other entries are ignored).

        Entries added in later releases may be missing (``abar``, ``protocol``, a schedule):
        they take the value maps had before. Raises ValueError naming the entry that is missing
        or of the wrong type or value (a damaged or foreign file).
        """
        types: dict[str, type | tuple[type, ...]] = {
            "lattice": list, "input_dim": int, "rule": str, "averaging": str, "refine": bool,
            "abar": str, "t_max": int, "schedules": dict, "a_init": (int, float),
            "min_dv": (int, float), "protocol": str, "continual": dict, "recover": bool,
            "sensing_noise": (int, float),
        }  # fmt: skip
        options: dict[str, Any] = {}
        for key, kind in types.items():
            if key not in entries:
                if key in _ADDED_LATER or key in ("continual", "recover", "sensing_noise"):
                    continue
                raise ValueError(f"config entry {key!r} is missing")
            value = entries[key]
            if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
                raise ValueError(f"config entry {key!r} is {value!r}, not of type {kind}")
            options[key] = value
        options = {**_ADDED_LATER, **options}
        schedules = options.pop("schedules")
        for name, pair in schedules.items():
            ok = isinstance(pair, list) and len(pair) == 2
            if name not in SCHEDULES or not ok or any(isinstance(x, bool) for x in pair):
                raise ValueError(f"config entry 'schedules' holds {name!r}: {pair!r}")
            options[name] = tuple(pair)
        if "continual" in options:
            try:
                options["continual"] = Continual(**options["continual"])
            except TypeError as exc:
                raise ValueError(f"config entry 'continual' is damaged ({exc})") from None
        return cls(**options)
