"""The tail of the hierarchical map's fine moves on the idealised grasp task.

After a few fine moves most objects are grasped to a few µm, but a few per cent end millimetres
or degrees off, near the wrist singularity (joint 5 near 0, where only θ4 + θ6 is defined) and
some with the wrist flipped; the means are carried by these few. :func:`tail` measures them:
for each seed and orientation range a fresh :class:`~learners.som.hierarchical.HierarchicalSOM`
trains on the oracle (:func:`~envs.studies.grasp_learning.train`, ``trials_per_leaf`` trials
per leaf, schedules over exactly that budget), then every fine-move variant (a copy of the
trained map with other fine-move options: nothing it learned changes) moves to the same objects
with a coarse and ``fine_moves`` fine moves. A training trial makes a coarse and ``pairs``
exploratory fine moves and is learned pair by pair (:func:`~envs.harness.trials.learn_from`;
``pairs=1``: one fine move and one ``learn``, as before): the budget is counted in trials.

Generators (:mod:`envs.harness.streams`): training targets from the seed's ``training`` stream,
the map's own generator from ``SeedSequence(seed, spawn_key=(7,))``, the objects from the
``validation`` stream (settings are chosen on these) or ``evaluation`` (held-out figures only).

A flip is a final pose whose θ5 has the other sign than the exact joints' or whose θ4 is more
than 90° from theirs (counted among the objects over the thresholds only).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.harness.evaluation import TAIL_BOUNDS
from envs.harness.streams import generator
from envs.harness.training import TRAINING_PAIRS
from envs.studies.grasp_learning import moves, train
from envs.studies.grasp_oracle import PoseOracle
from learners.som.hierarchical import HierarchicalSOM
from learners.som.hierarchical_config import HierarchicalConfig
from models.puma560 import ARM_REACH
from models.puma560.grasp import NARROW, READY, WIDE, OrientationRange
from models.puma560.kinematics import DH

#: The orientation ranges measured, by name.
RANGES: dict[str, OrientationRange] = {"narrow": NARROW, "wide": WIDE}
#: The fine-move variants compared: options of a copy of the trained map.
VARIANTS: dict[str, dict[str, Any]] = {
    "published": {"refine": False, "backtrack": False},
    "halving": {"refine": True, "backtrack": True, "trust_radius": 0.0},
    "trust": {"refine": True, "backtrack": True, "trust_radius": 0.2},
}
#: The spawn key of the map's own generator (apart from every stream of envs.harness.streams).
MAP_SPAWN_KEY = (7,)


@dataclass(frozen=True)
class Row:
    """One variant on one seed's objects after ``fine_moves`` fine moves (of ``moves_made``).

    position_mm, position_pct (of the arm's reach), orientation_deg: means over the objects;
    tail_pct: share (%) over 1 mm or 1°; worst_mm, worst_deg: the largest errors; flips: the
    objects of the tail whose wrist flipped (module docstring); tail: their count.
    """

    range_name: str
    seed: int
    variant: str
    objects: int
    trials: int
    fine_moves: int
    position_mm: float
    position_pct: float
    orientation_deg: float
    tail_pct: float
    tail: int
    worst_mm: float
    worst_deg: float
    flips: int


def flipped(theta: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """Whether joints ``theta`` (..., 6) hold the other wrist configuration than ``exact``:
    θ5 of the other sign, or θ4 more than 90° away."""
    sign = np.sign(theta[..., 4]) != np.sign(exact[..., 4])
    return sign | (np.abs(theta[..., 3] - exact[..., 3]) > np.pi / 2)


def rows_of(
    range_name: str, seed: int, variant: str, trials: int, exact: np.ndarray,
    position: np.ndarray, orientation: np.ndarray, theta: np.ndarray, report: Sequence[int],
) -> list[Row]:  # fmt: skip
    """Rows after each of the fine moves ``report`` from errors (N, 1 + K) and joints
    (N, 1 + K, 6) of N objects whose exact joints are ``exact`` (N, 6)."""
    out = []
    for k in report:
        p, a = position[:, k], orientation[:, k]
        bad = (p > TAIL_BOUNDS[0]) | (a > TAIL_BOUNDS[1])  # over 1 mm or 1°
        out.append(
            Row(
                range_name,
                seed,
                variant,
                len(p),
                trials,
                k,
                1e3 * p.mean(),
                100.0 * p.mean() / ARM_REACH,
                float(np.degrees(a.mean())),
                100.0 * bad.mean(),
                int(bad.sum()),
                1e3 * p.max(),
                float(np.degrees(a.max())),
                int((bad & flipped(theta[:, k], exact)).sum()),
            )
        )
    return out


def tail(
    seeds: Sequence[int] = (0,),
    ranges: Sequence[str] = ("narrow", "wide"),
    variants: Mapping[str, Mapping[str, Any]] | None = None,
    objects: int = 2000,
    trials_per_leaf: float = 2.0,
    fine_moves: int = 5,
    report: Sequence[int] = (3, 5),
    stream: str = "validation",
    config: HierarchicalConfig | None = None,
    pairs: int = TRAINING_PAIRS,
) -> list[Row]:
    """Rows per range, seed, variant and reported fine move (see the module docstring).

    ``config``: the map's options for training (default: the defaults); ``variants``: name ->
    fine-move options of the copy that moves (default :data:`VARIANTS`); ``pairs``: pairs of
    moves learned per training trial (``train``; 1: one fine move, as before).
    """
    if stream not in ("validation", "evaluation"):
        raise ValueError(f"objects come from 'validation' or 'evaluation', not {stream!r}")
    variants = VARIANTS if variants is None else variants
    config = config or HierarchicalConfig()
    trials = max(1, round(trials_per_leaf * config.n_positions * config.n_orientations))
    rows: list[Row] = []
    for range_name in ranges:
        oracle = PoseOracle(*config.image_size, orientations=RANGES[range_name])
        for seed in seeds:
            som = HierarchicalSOM(
                DH.lower, DH.upper, READY, HierarchicalConfig.of(config, t_max=trials),
                rng=np.random.default_rng(np.random.SeedSequence(seed, spawn_key=MAP_SPAWN_KEY)),
            )  # fmt: skip
            train(som, oracle, trials, generator(seed, "training"), pairs)
            poses, exact = oracle.targets(generator(seed, stream), objects)
            pixels = oracle.pixels(poses)
            for name, options in variants.items():
                moving = som.with_fine_moves(**options)
                theta = moves(moving, oracle, pixels, fine_moves)
                position, orientation = oracle.errors(poses[:, None], theta)
                rows += rows_of(
                    range_name, seed, name, trials, exact, position, orientation, theta, report
                )
    return rows


def format_rows(rows: Sequence[Row]) -> str:
    """The rows as a Markdown table."""
    lines = [
        "| range | seed | variant | objects | fine | mm | % reach | ° | > 1 mm or 1° | worst "
        "mm / ° | flips |",
        "|" + "---|" * 11,
    ]
    for r in rows:
        lines.append(
            f"| {r.range_name} | {r.seed} | {r.variant} | {r.objects} | {r.fine_moves} | "
            f"{r.position_mm:.3f} | {r.position_pct:.4f} | {r.orientation_deg:.3f} | "
            f"{r.tail_pct:.2f} % ({r.tail}) | {r.worst_mm:.1f} / {r.worst_deg:.1f} | "
            f"{r.flips} |"
        )
    return "\n".join(lines)
