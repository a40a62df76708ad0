"""The options of the hierarchical visuomotor map, in one frozen dataclass.

:class:`HierarchicalConfig` is the only list of the options of
:class:`~learners.som.hierarchical.HierarchicalSOM`: its constructor takes them by name and its
checkpoint stores :meth:`HierarchicalConfig.to_dict` and reads it back with
:meth:`HierarchicalConfig.from_dict`. The meaning of every option is in the map's module
docstring.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

from learners.guards import option_number
from learners.som.schedules import Schedule

#: The schedules of the map, in the order its checkpoint stores them.
SCHEDULES = ("eps", "sigma", "eps_out", "sigma_out", "explore")
#: Leaves (position nodes × orientation nodes) a map may have: 10^6 leaves of a 6 × 12 local
#: map hold about 0.6 GB.
MAX_LEAVES = 1_000_000

# Schedules x_i -> x_f over t_max trials (σ in lattice units of each lattice); docs/decisions.md,
# "The map" (the hierarchical map), says where they come from.
DEFAULT_EPS = Schedule(1.0, 0.01)
DEFAULT_SIGMA = Schedule(2.0, 0.6)
DEFAULT_EPS_OUT = Schedule(0.9, 0.1)
DEFAULT_SIGMA_OUT = Schedule(2.0, 0.6)
#: Exploration std of training fine moves, rad.
DEFAULT_EXPLORE = Schedule(0.05, 0.005)
DEFAULT_T_MAX = 10_000
#: Trials with |Δf| below this (px) are skipped: the Widrow-Hoff step divides by |Δf|².
DEFAULT_MIN_DV = 1e-3
#: Weight of the orientation features (marker offsets) against the position features: the
#: markers sit closer together than the hand travels, so an orientation change moves the
#: offsets less than a position change moves the first marker; the gain evens out how strongly
#: the joints show in the features, which the Widrow-Hoff rule needs to learn every direction
#: at a similar speed.
DEFAULT_ORIENTATION_GAIN = 4.0
#: rad: the fine moves' trust radius at the coarse move (``trust_radius``), chosen among 0.1,
#: 0.2 and 0.4 on validation objects of both orientation ranges (envs/studies/pose_tail.py).
DEFAULT_TRUST_RADIUS = 0.2


def _number(name: str, value: Any, kind: type) -> Any:
    """``value`` as ``kind`` (int or float), else ValueError naming the option."""
    return option_number("HierarchicalConfig", name, value, kind)


def _shape(name: str, value: Any) -> tuple[int, ...]:
    try:
        shape = tuple(_number(name, n, int) for n in value)
    except TypeError:
        shape = ()
    if not shape or min(shape) < 1 or len(shape) > 3:
        raise ValueError(
            f"HierarchicalConfig.{name} must be 1 to 3 positive sizes, e.g. (6, 6, 4), "
            f"got {value!r}"
        )
    return shape


@dataclass(frozen=True)
class HierarchicalConfig:
    """Every option of the hierarchical map (see ``learners/som/hierarchical.py``). Values are
    checked on construction; schedules may be a :class:`~learners.som.schedules.Schedule`, an
    (initial, final) pair or one constant.

    Args:
        position_lattice: shape of the lattice over the object's position (the first marker's
            four pixels).
        orientation_lattice: shape of the lattice nested at every position node, over the
            object's orientation (the other markers' pixel offsets from the first).
        image_size: (width, height) px of both cameras: where the nodes start.
        t_max: trials over which the schedules fall from their initial to their final value.
        eps, sigma: ε(t) and σ(t) of the input-weight update (σ in lattice units).
        eps_out, sigma_out: ε'(t) and σ'(t) of the output (θ, A) update.
        explore: std (rad) of the noise of fine commands made with ``explore=True``.
        min_dv: trials whose sensed change |Δf| (px) is below this are skipped.
        orientation_gain: weight of the orientation features against the position features.
        refine: correct the fine moves' map between the fine moves of one target (Broyden).
        transport: every leaf learns the winner's θ* moved to its own centre along A*.
        backtrack: a fine move after which the cameras see the hand no nearer the object (in
            feature space) is undone: the next one starts again from the best pose seen, with
            half the step (the first releases', ``trust_radius=0``) or half the trust radius.
        trust_radius: rad, > 0 with ``backtrack``: no fine move turns any joint by more than a
            trust radius that starts here at every coarse move, doubles after a fine move that
            brings the hand nearer than any before and halves after an undone one (to half that
            move's largest joint change if it was smaller) (not in the
            papers); 0: the first releases' backtracking (the step halved). Without
            ``backtrack`` it does nothing.
    Raises:
        ValueError: one line naming the option and what it must be.
    """

    position_lattice: tuple[int, ...] = (8, 8, 6)
    orientation_lattice: tuple[int, ...] = (2, 2, 2)
    image_size: tuple[int, int] = (320, 240)
    t_max: int = DEFAULT_T_MAX
    eps: Schedule = DEFAULT_EPS
    sigma: Schedule = DEFAULT_SIGMA
    eps_out: Schedule = DEFAULT_EPS_OUT
    sigma_out: Schedule = DEFAULT_SIGMA_OUT
    explore: Schedule = DEFAULT_EXPLORE
    min_dv: float = DEFAULT_MIN_DV
    orientation_gain: float = DEFAULT_ORIENTATION_GAIN
    refine: bool = True
    transport: bool = True
    backtrack: bool = True
    trust_radius: float = DEFAULT_TRUST_RADIUS

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        put("position_lattice", _shape("position_lattice", self.position_lattice))
        put("orientation_lattice", _shape("orientation_lattice", self.orientation_lattice))
        leaves = math.prod(self.position_lattice) * math.prod(self.orientation_lattice)
        if leaves > MAX_LEAVES:
            raise ValueError(
                f"HierarchicalConfig: {leaves:,} leaves (position × orientation nodes); at most "
                f"{MAX_LEAVES:,} fit in memory"
            )
        size = _shape("image_size", self.image_size)
        if len(size) != 2:
            raise ValueError(f"HierarchicalConfig.image_size must be (width, height), got {size}")
        put("image_size", size)
        put("t_max", _number("t_max", self.t_max, int))
        if self.t_max < 1:
            raise ValueError(f"HierarchicalConfig.t_max must be >= 1, got {self.t_max}")
        put("min_dv", _number("min_dv", self.min_dv, float))
        if self.min_dv < 0:
            raise ValueError(f"HierarchicalConfig.min_dv must be >= 0, got {self.min_dv}")
        put("orientation_gain", _number("orientation_gain", self.orientation_gain, float))
        if self.orientation_gain <= 0:
            raise ValueError(
                f"HierarchicalConfig.orientation_gain must be > 0, got {self.orientation_gain}"
            )
        put("trust_radius", _number("trust_radius", self.trust_radius, float))
        if self.trust_radius < 0:
            raise ValueError(
                f"HierarchicalConfig.trust_radius must be >= 0 (rad), got {self.trust_radius}"
            )
        for name in ("refine", "transport", "backtrack"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(
                    f"HierarchicalConfig.{name} must be True or False, got {getattr(self, name)!r}"
                )
        for name in SCHEDULES:
            put(name, self._schedule(name, getattr(self, name)))
        for name in ("eps", "eps_out"):
            if max(getattr(self, name).initial, getattr(self, name).final) > 1.0:
                raise ValueError(f"{name} is a learning rate in [0, 1], got {getattr(self, name)}")

    @staticmethod
    def _schedule(name: str, value: Any) -> Schedule:
        try:
            schedule = Schedule.of(value)
            for end in (schedule.initial, schedule.final):
                _number(name, end, float)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"HierarchicalConfig.{name} must be a Schedule, an (initial, final) pair or a "
                f"number > 0, got {value!r} ({exc})"
            ) from None
        return schedule

    @property
    def n_positions(self) -> int:
        return math.prod(self.position_lattice)

    @property
    def n_orientations(self) -> int:
        return math.prod(self.orientation_lattice)

    @classmethod
    def names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @classmethod
    def of(cls, config: HierarchicalConfig | None = None, **options: Any) -> HierarchicalConfig:
        """``config`` (default: the defaults) with ``options`` changed; an unknown option name
        is a ValueError listing the valid ones."""
        unknown = sorted(set(options) - set(cls.names()))
        if unknown:
            raise ValueError(
                f"unknown option(s) {', '.join(unknown)}; valid: {', '.join(cls.names())}"
            )
        return replace(config or cls(), **options)

    def to_dict(self) -> dict[str, Any]:
        """The options as JSON-ready entries, as the map's checkpoint stores them."""
        return {
            "position_lattice": list(self.position_lattice),
            "orientation_lattice": list(self.orientation_lattice),
            "image_size": list(self.image_size),
            "t_max": self.t_max,
            "schedules": {k: [getattr(self, k).initial, getattr(self, k).final] for k in SCHEDULES},
            "min_dv": self.min_dv,
            "orientation_gain": self.orientation_gain,
            "refine": self.refine,
            "transport": self.transport,
            "backtrack": self.backtrack,
            "trust_radius": self.trust_radius,
        }

    @classmethod
    def from_dict(cls, entries: dict[str, Any]) -> HierarchicalConfig:
        """The configuration stored by :meth:`to_dict`; ValueError naming an entry that is
        missing or of the wrong type (a damaged or foreign file). ``backtrack``, added after
        the first maps were saved, takes its default when missing; ``trust_radius``, added
        later, takes 0 (the fine moves those maps were trained and measured with)."""
        types: dict[str, type | tuple[type, ...]] = {
            "position_lattice": list, "orientation_lattice": list, "image_size": list,
            "t_max": int, "schedules": dict, "min_dv": (int, float),
            "orientation_gain": (int, float), "refine": bool, "transport": bool,
            "backtrack": bool, "trust_radius": (int, float),
        }  # fmt: skip
        options: dict[str, Any] = {}
        for key, kind in types.items():
            if key == "backtrack" and key not in entries:
                continue
            if key == "trust_radius" and key not in entries:
                options[key] = 0.0
                continue
            value = entries.get(key)
            if not isinstance(value, kind) or (kind is not bool and isinstance(value, bool)):
                raise ValueError(f"config entry {key!r} is {value!r}, not of type {kind}")
            options[key] = value
        schedules = options.pop("schedules")
        if sorted(schedules) != sorted(SCHEDULES):
            raise ValueError(f"config entry 'schedules' names {sorted(schedules)}, not {SCHEDULES}")
        for name, pair in schedules.items():
            if not (isinstance(pair, list) and len(pair) == 2):
                raise ValueError(f"config entry 'schedules' holds {name!r}: {pair!r}")
            options[name] = tuple(pair)
        return cls(**options)
