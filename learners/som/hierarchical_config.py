"""The options of the hierarchical visuomotor map, in one frozen dataclass.

:class:`HierarchicalConfig` is the only list of the options of
:class:`~learners.som.hierarchical.HierarchicalSOM`: its constructor takes them by name and its
checkpoint stores :meth:`HierarchicalConfig.to_dict` and reads it back with
:meth:`HierarchicalConfig.from_dict`. The meaning of every option is in the map's module
docstring. Each field is declared once with its metadata (``learners/som/options.py``); the
checkpoint entries and a training run's options are generated from the fields.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

from learners.som.options import (
    OPTION_LIMIT,
    check_common,
    entries,
    from_entries,
    number,
    option,
    positive_shape,
    schedule_names,
)
from learners.som.schedules import Schedule

_OWNER = "HierarchicalConfig"
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
#: ... at most this: beyond, the position features no longer count in the winner search.
MAX_ORIENTATION_GAIN = 1e3
#: px: the largest image side a camera of the map may have.
MAX_IMAGE_SIDE = 100_000
#: Trials a schedule may run over: 2^53, every count up to it exact as a float.
MAX_T_MAX = 2**53
#: rad: the fine moves' trust radius at the coarse move (``trust_radius``), chosen among 0.1,
#: 0.2 and 0.4 on validation objects of both orientation ranges (envs/studies/pose_tail.py).
DEFAULT_TRUST_RADIUS = 0.2


def _shape(name: str, value: Any) -> tuple[int, ...]:
    shape = positive_shape(_OWNER, name, value)
    if not shape or len(shape) > 3:
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

    position_lattice: tuple[int, ...] = option(
        (8, 8, 6), "shape of the lattice over the object's position (marker 1's pixels)",
        run=True, run_as="lattice",
    )  # fmt: skip
    orientation_lattice: tuple[int, ...] = option(
        (2, 2, 2), "shape of the lattice nested at every position node, over the orientation",
        run=True,
    )  # fmt: skip
    image_size: tuple[int, int] = option((320, 240), "(width, height) px of both cameras")
    t_max: int = option(DEFAULT_T_MAX, "trials over which the schedules fall to their final value")
    eps: Schedule = option(DEFAULT_EPS, "epsilon(t) of the input-weight update")  # noqa: RUF009 (a field)
    sigma: Schedule = option(DEFAULT_SIGMA, "sigma(t) of the input-weight update, lattice units")  # noqa: RUF009 (a field)
    eps_out: Schedule = option(DEFAULT_EPS_OUT, "epsilon'(t) of the output (theta, A) update")  # noqa: RUF009 (a field)
    sigma_out: Schedule = option(DEFAULT_SIGMA_OUT, "sigma'(t) of the output (theta, A) update")  # noqa: RUF009 (a field)
    explore: Schedule = option(  # noqa: RUF009 (a field)
        DEFAULT_EXPLORE, "std (rad) of the noise of exploratory (training) fine moves"
    )
    min_dv: float = option(
        DEFAULT_MIN_DV, "trials whose sensed change |df| (px) is below are skipped"
    )
    orientation_gain: float = option(
        DEFAULT_ORIENTATION_GAIN, "weight of the orientation features against the position ones"
    )
    refine: bool = option(
        True, "correct the fine moves' map between fine moves of one target (Broyden)", run=True
    )
    transport: bool = option(True, "every leaf learns the winner's theta* moved to its centre")
    backtrack: bool = option(
        True, "undo a fine move after which the hand is seen no nearer the object",
        added_later=True,
    )  # fmt: skip
    trust_radius: float = option(
        DEFAULT_TRUST_RADIUS, "rad: no fine move turns a joint more (with backtrack; 0: halving)",
        added_later=0.0,
    )  # fmt: skip

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        check_common(self)
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
        if max(size) > MAX_IMAGE_SIDE:
            raise ValueError(
                f"HierarchicalConfig.image_size {size} is beyond {MAX_IMAGE_SIDE} px a side"
            )
        put("image_size", size)
        for name, kind, least, most, strict in (
            ("t_max", int, 1, MAX_T_MAX, False), ("min_dv", float, 0, OPTION_LIMIT, False),
            ("orientation_gain", float, 0, MAX_ORIENTATION_GAIN, True),
            ("trust_radius", float, 0, OPTION_LIMIT, False),
        ):  # fmt: skip
            put(name, number(_OWNER, name, getattr(self, name), kind, least, most, strict))

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
        """The options as JSON-ready entries, as the map's checkpoint stores them
        (``learners.som.options.entries``)."""
        return entries(self)

    @classmethod
    def from_dict(cls, stored: dict[str, Any]) -> HierarchicalConfig:
        """The configuration stored by :meth:`to_dict`; ValueError naming an entry that is
        missing or of the wrong type (a damaged or foreign file). ``backtrack``, added after
        the first maps were saved, takes its default when missing; ``trust_radius``, added
        later, takes 0 (the fine moves those maps were trained and measured with): each
        field's ``added_later``."""
        return from_entries(cls, stored)


#: The schedules of the map, in the order its checkpoint stores them.
SCHEDULES = schedule_names(HierarchicalConfig)
