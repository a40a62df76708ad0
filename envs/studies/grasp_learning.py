"""The hierarchical map on the idealised grasp task: error against training trials per leaf.

Seeded runs through :class:`~envs.studies.grasp_oracle.PoseOracle` (exact projection, joints
set exactly): for each training budget a fresh :class:`~learners.som.hierarchical.HierarchicalSOM`
trains on its own trials (coarse move, ``pairs`` exploratory fine moves, one ``learn`` per
consecutive pair of moves: :func:`~envs.harness.trials.learn_from`; 1 by default) with its
schedules run over exactly that budget, then moves to held-out targets with a coarse and
``fine_moves`` fine moves. Every held-out trial is counted (the oracle sees every marker). The
floor beside it is :class:`~learners.baselines.pose_ik.PoseIK` through the same cameras.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.harness import streams
from envs.harness.trials import Trial, learn_from
from envs.studies.grasp_oracle import PoseOracle
from learners.base import Controller
from learners.baselines.pose_ik import PoseIK
from learners.som.hierarchical import HierarchicalSOM
from learners.som.hierarchical_config import HierarchicalConfig
from models.puma560 import ARM_REACH
from models.puma560.grasp import READY
from models.puma560.kinematics import DH

#: Training budgets, in trials per leaf of the map.
TRIALS_PER_LEAF = (0.5, 1.0, 2.0, 4.0)
FINE_MOVES = 3
TEST_TARGETS = 1000
#: The spawn key of the map's own generator under the seed (the training and test targets come
#: from the seed's training and evaluation streams, envs.harness.streams); every budget starts
#: the map and its training targets from the same generators.
MAP_SPAWN_KEY = (0,)


@dataclass(frozen=True)
class Row:
    """Errors of one controller over the held-out targets, after the coarse and each fine move.

    position_mm, orientation_deg: (1 + fine_moves,) means; position_pct = position / reach, %.
    """

    name: str
    trials: int
    trials_per_leaf: float
    position_mm: np.ndarray
    position_pct: np.ndarray
    orientation_deg: np.ndarray
    position_median_mm: np.ndarray
    orientation_median_deg: np.ndarray


def train(
    som: HierarchicalSOM,
    oracle: PoseOracle,
    trials: int,
    rng: np.random.Generator,
    pairs: int = 1,
) -> None:
    """``trials`` training trials of the map on targets drawn from ``rng``: a coarse and
    ``pairs`` exploratory fine moves each, learned pair by pair
    (:func:`~envs.harness.trials.learn_from`)."""
    poses, _ = oracle.targets(rng, trials)
    for u in oracle.pixels(poses):
        som.reset()
        trial = Trial(u)
        for k in range(pairs + 1):
            sensed = trial.sensed_px[-1] if k else None
            command = som.act(u) if sensed is None else som.act(u, sensed, explore=True)
            trial.commands.append(command)
            trial.sensed_px.append(oracle.hand_pixels(command))
        learn_from(som, trial, pairs)


def moves(
    controller: Controller, oracle: PoseOracle, pixels: np.ndarray, fine_moves: int
) -> np.ndarray:
    """Joint commands (N, 1 + fine_moves, 6) of a coarse and ``fine_moves`` fine moves."""
    out = np.empty((len(pixels), 1 + fine_moves, 6))
    for i, u in enumerate(pixels):
        controller.reset()
        out[i, 0] = controller.act(u)
        for k in range(fine_moves):
            out[i, k + 1] = controller.act(u, oracle.hand_pixels(out[i, k]))
    return out


def _row(name: str, trials: int, leaves: int, position, orientation) -> Row:
    return Row(
        name,
        trials,
        trials / leaves,
        1e3 * position.mean(axis=0),
        100.0 * position.mean(axis=0) / ARM_REACH,
        np.degrees(orientation.mean(axis=0)),
        1e3 * np.median(position, axis=0),
        np.degrees(np.median(orientation, axis=0)),
    )


def table(
    seed: int = 0,
    config: HierarchicalConfig | None = None,
    trials_per_leaf: tuple[float, ...] = TRIALS_PER_LEAF,
    test_targets: int = TEST_TARGETS,
    fine_moves: int = FINE_MOVES,
    pairs: int = 1,
) -> list[Row]:
    """One row per training budget, then the PoseIK floor (see the module docstring);
    ``pairs``: pairs of moves learned per training trial (:func:`train`)."""
    config = config or HierarchicalConfig()
    oracle = PoseOracle(*config.image_size)
    map_seed = np.random.SeedSequence(seed, spawn_key=MAP_SPAWN_KEY)
    poses, _ = oracle.targets(streams.generator(seed, "evaluation"), test_targets)
    pixels = oracle.pixels(poses)
    leaves = config.n_positions * config.n_orientations
    rows = []
    for per_leaf in trials_per_leaf:
        trials = max(1, round(per_leaf * leaves))
        som = HierarchicalSOM(
            DH.lower, DH.upper, READY, HierarchicalConfig.of(config, t_max=trials),
            rng=np.random.default_rng(map_seed),
        )  # fmt: skip
        train(som, oracle, trials, streams.generator(seed, "training"), pairs)
        errors = oracle.errors(poses[:, None], moves(som, oracle, pixels, fine_moves))
        rows.append(_row("HierarchicalSOM", trials, leaves, *errors))
    floor = PoseIK(oracle.cameras.triangulate, oracle.base)
    errors = oracle.errors(poses[:, None], moves(floor, oracle, pixels, fine_moves))
    rows.append(_row("PoseIK (floor)", 0, leaves, *errors))
    return rows


def format_table(rows: list[Row]) -> str:
    """The rows as a Markdown table: mean position (mm, % of reach) and orientation (°) after
    the coarse move (c) and each fine move (f1, f2, ...)."""
    moves_ = len(rows[0].position_mm)
    labels = ["c"] + [f"f{k}" for k in range(1, moves_)]
    head = (
        "| controller | trials | per leaf | "
        + " | ".join(f"{m}: mm / % / °" for m in labels)
        + " |"
    )
    lines = [head, "|" + "---|" * (3 + moves_)]
    for r in rows:
        cells = [
            f"{r.position_mm[k]:.3g} / {r.position_pct[k]:.3g} / {r.orientation_deg[k]:.3g}"
            for k in range(moves_)
        ]
        budget = f"{r.trials} | {r.trials_per_leaf:.2g}" if r.trials else "- | -"
        lines.append(f"| {r.name} | {budget} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
