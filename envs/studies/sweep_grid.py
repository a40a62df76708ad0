"""Sweeps: a grid of training runs, each cell a normal run folder
(``envs.harness.training.Trainer``) plus its held-out evaluation, one row per cell in a results
table.

A grid maps each :class:`~envs.harness.training.RunConfig` field (plus ``robot``, the short name
of ``env`` in the robot registry, :func:`envs.robots.sweep_names`: "riacs", "puma", "ur5e",
"panda", ..., or "grasp" for the grasp task PumaGrasp-v0) to one value or a list of
values; the cells are all combinations. ``lattice`` and ``orientation_lattice`` values are
"12x7x4" or one size n for an n×n×n cube; ``image_size`` values are WIDTHxHEIGHT, "640x480" (or
give ``width`` and ``height``). A grasp cell trains the hierarchical map: ``lattice`` is its
position lattice and ``orientation_lattice`` the one nested at every position node, each the
map's default (``HierarchicalConfig``) unless the grid gives it; its neurons are the map's leaves
(position × orientation nodes), which ``trials_per_neuron`` counts too. The reach map's options
and ``orientation_lattice`` are refused in a grid whose envs they do not fit.

Each cell lives in ``OUT/cells/<name>/``, its name made of its values and a hash of its whole
configuration, so a cell is found again by any sweep that contains it:

    checkpoint.npz, metrics.jsonl          the run folder (resumable, as ``train.py`` writes)
    attempts.jsonl                         one line per attempt: worker pid, starting trial
    progress.json                          last checkpointed trial (for progress displays)
    cell.json                              the cell's results row, written last (= finished)

and ``OUT/cells/<name>.lock``, held while a process works on the cell: a second sweep on the
same OUT, or a task Ray retries while the first attempt still runs, waits for it and then
finds the cell finished (or resumes it from its checkpoint if the first attempt died).

Results rows count all held-out trials: a trial that stopped because a marker was not seen
keeps the distance where it stopped in every later column. A grasp cell's row also gives the
hand's orientation error after each move (``mean_deg``, ``median_deg``, ``p90_deg``, degrees),
counted the same way.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import shutil
import time
import typing
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from envs.grasp import GRASP_ENV_IDS
from envs.harness.evaluation import Evaluation, evaluate
from envs.harness.run_folder import locked, write_json
from envs.harness.training import (
    REACH_ONLY,
    SETTINGS,
    RunConfig,
    Trainer,
    check_env_image_size,
)
from envs.robots import sweep_names
from envs.sizes import format_lattice, parse_lattice, parse_size
from learners.persistence import CheckpointError
from learners.som.hierarchical_config import HierarchicalConfig

CELL_FILE, PROGRESS_FILE, ATTEMPTS_FILE = "cell.json", "progress.json", "attempts.jsonl"
LOCK_SUFFIX = ".lock"
#: The axes shown in a cell's folder name (the hash covers everything else).
NAME_AXES = ("robot", "lattice", "orientation_lattice", "rule", "protocol", "refine", "sensing",
             "control", "seed")  # fmt: skip


def _fields() -> dict[str, Any]:
    """Setting -> default value as a run spells it (its type parses the grid's values): the
    RunConfig fields and the maps' run options (``SETTINGS``)."""
    default = RunConfig()
    own = {f.name: getattr(default, f.name) for f in fields(RunConfig) if f.name != "map"}
    return own | SETTINGS


def _type(axis: str, default: Any) -> Any:
    """The type of ``axis``'s values: its default's, or for a field that defaults to None the
    annotation's (``str | None`` -> str)."""
    if default is not None:
        return type(default)
    hint = typing.get_type_hints(RunConfig)[axis]
    return next(a for a in typing.get_args(hint) if a is not type(None))


def robot_word(env_id: str) -> str:
    """The grid's word for ``env_id`` (``robot=puma``), or the id itself if it has none."""
    return {env: word for word, env in sweep_names().items()}.get(env_id, env_id)


def parse_value(axis: str, value: Any) -> Any:
    """One grid value of ``axis`` as the RunConfig field wants it."""
    if axis == "robot":
        robots = sweep_names()
        if value not in robots:
            raise ValueError(f"unknown robot {value!r}; valid robots: {', '.join(robots)}")
        return robots[value]
    if axis == "image_size":
        return parse_size(value)
    default = _fields()[axis]
    if axis in ("lattice", "orientation_lattice"):
        return (int(value),) * 3 if str(value).isdigit() else parse_lattice(value)
    if isinstance(default, bool):
        if str(value).lower() not in ("true", "false", "1", "0"):
            raise ValueError(f"{axis} takes true or false, got {value!r}")
        return str(value).lower() in ("true", "1")
    return _type(axis, default)(value)


def expand(grid: dict[str, Any]) -> list[RunConfig]:
    """All cells of ``grid`` (axis -> value or list of values), in a fixed order.

    ``trials_per_neuron`` k (one value) raises each cell's trials to at least k·N, N the cell's
    :func:`neurons`."""
    grid = dict(grid)
    per_neuron = grid.pop("trials_per_neuron", 0)
    if isinstance(per_neuron, list):
        if len(per_neuron) != 1:
            raise ValueError(f"trials_per_neuron takes one value, got {per_neuron}")
        per_neuron = per_neuron[0]
    per_neuron = float(per_neuron)
    valid = {*_fields(), "robot", "image_size"}
    unknown = sorted(set(grid) - valid)
    if unknown:
        raise ValueError(f"unknown grid axes {unknown}; valid axes: {', '.join(sorted(valid))}")
    if "robot" in grid and "env" in grid:
        raise ValueError(f"give the arm as robot ({', '.join(sweep_names())}) or env, not both")
    if "image_size" in grid and {"width", "height"} & set(grid):
        raise ValueError("give the image size as image_size (640x480) or width and height")
    axes = {k: v if isinstance(v, list) else [v] for k, v in grid.items()}
    values = {("env" if k == "robot" else k): [parse_value(k, v) for v in vs]
              for k, vs in axes.items()}  # fmt: skip
    check_task_axes(values)
    cells = itertools.product(*values.values())
    configs = [_config(dict(zip(values, c, strict=True))) for c in cells]
    return [replace(c, trials=max(c.trials, round(per_neuron * neurons(c)))) for c in configs]


def check_task_axes(values: dict[str, list[Any]]) -> None:
    """ValueError (one line) for an axis that does not fit one of the grid's envs: the nested
    lattice is the pose map's, the reach map's own options (``REACH_ONLY``) are not the pose
    map's. ``values`` maps RunConfig fields to their parsed grid values."""
    default = _fields()
    envs = values.get("env", [default["env"]])
    reach = [e for e in envs if e not in GRASP_ENV_IDS]
    pose = [e for e in envs if e in GRASP_ENV_IDS]
    if reach and "orientation_lattice" in values:
        raise ValueError(
            f"orientation_lattice is an axis of the grasp task only (robot=grasp, "
            f"{', '.join(GRASP_ENV_IDS)}), not of {', '.join(reach)}; sweep the reach arms in a "
            "grid of their own"
        )
    for axis in REACH_ONLY:
        changed = [v for v in values.get(axis, []) if v != default[axis]]
        if pose and changed:
            raise ValueError(
                f"{axis}={changed[0]} is an option of the reach map; {pose[0]} (robot=grasp) "
                f"trains the hierarchical map: leave {axis} out or sweep the grasp task in a grid "
                "of its own"
            )


def neurons(config: RunConfig) -> int:
    """The neurons N of a cell's map: the lattice's nodes, or on a grasp env the hierarchical
    map's leaves (position nodes × orientation nodes), each of which learns its own joints."""
    nested = config.map
    if isinstance(nested, HierarchicalConfig):
        return nested.n_positions * nested.n_orientations
    return math.prod(config.lattice)


def _config(values: dict[str, Any]) -> RunConfig:
    """The RunConfig of one cell's values (``image_size`` (width, height) sets both fields),
    its image size checked against the cameras of its env; a grasp cell's lattices are the
    hierarchical map's defaults unless given (never the reach map's default lattice)."""
    if "image_size" in values:
        values["width"], values["height"] = values.pop("image_size")
    config = RunConfig.of(**values)  # ValueError for an env that is not a reach env
    check_env_image_size(config.env, config.width, config.height)
    return config


def cell_name(config: RunConfig) -> str:
    """Readable, unique folder name: the main axes' values and a hash of the configuration."""
    values = config.to_stored()
    robot = robot_word(config.env)
    parts = [robot if axis == "robot" else values.get(axis) for axis in NAME_AXES]
    text = "_".join(
        format_lattice(p) if isinstance(p, (tuple, list)) else str(p)
        for p in parts
        if p is not None
    )
    digest = hashlib.sha256(json.dumps(values, sort_keys=True).encode()).hexdigest()[:8]
    return f"{text}_{digest}"


def errors_all_counted(distances: np.ndarray) -> np.ndarray:
    """(n, moves) distances with NaN after a trial stopped -> the distance where it stopped
    carried forward (a trial with no move at all stays NaN)."""
    out = distances.copy()
    for k in range(1, out.shape[1]):
        missing = np.isnan(out[:, k])
        out[missing, k] = out[missing, k - 1]
    return out


def run_cell(config: RunConfig, folder: Path, checkpoint_every: int = 1000) -> dict[str, Any]:
    """Train (or resume) one cell, evaluate it on the held-out targets, write cell.json.

    Returns the cell's results row. A finished cell is returned as it is. Waits while another
    process works on the same cell (its lock, ``<folder>.lock``).
    """
    folder = Path(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    with locked(folder.with_name(folder.name + LOCK_SUFFIX)):
        return _run_cell(config, folder, checkpoint_every)


def _run_cell(config: RunConfig, folder: Path, checkpoint_every: int) -> dict[str, Any]:
    if (folder / CELL_FILE).is_file():
        return json.loads((folder / CELL_FILE).read_text())
    start = time.perf_counter()
    try:
        trainer = Trainer.resume(folder)
    except CheckpointError:  # nothing to resume (or unusable): start the cell afresh
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        trainer = Trainer(config, folder)
    if trainer.config != config:
        raise CheckpointError(f"{folder} holds another configuration: {trainer.config}")
    with open(folder / ATTEMPTS_FILE, "a") as f:
        f.write(json.dumps({"pid": os.getpid(), "start_trial": trainer.trial}) + "\n")

    def progress(trial: int, running: dict[str, float]) -> None:
        if trial % checkpoint_every == 0:  # Trainer.run has just saved a checkpoint
            write_json(folder / PROGRESS_FILE, {"trial": trial, "pid": os.getpid()})

    try:
        trainer.run(checkpoint_every=checkpoint_every, progress=progress)
        env = config.make_env("evaluation")
        try:
            result = evaluate(env, trainer.som, config.eval_trials, config.fine_moves)
        finally:
            env.close()
        som = trainer.som
    finally:
        trainer.close()
    errors_mm = errors_all_counted(result.distances) * 1e3  # (n, moves)
    n = neurons(config)
    row = {
        "cell": folder.name,
        **{k: list(v) if isinstance(v, tuple) else v for k, v in config.to_stored().items()},
        "robot": robot_word(config.env),
        "neurons": n,
        "n_per_axis": round(n ** (1 / 3), 6),
        "learned_trials": som.t,
        "eval_trials": len(errors_mm),
        "complete_fraction": float(np.mean(np.all(np.isfinite(result.distances), axis=1))),
        "mean_mm": np.mean(errors_mm, axis=0).round(5).tolist(),
        "median_mm": np.median(errors_mm, axis=0).round(5).tolist(),
        "p90_mm": np.percentile(errors_mm, 90, axis=0).round(5).tolist(),
        "mean_percent_reach": (np.mean(errors_mm, axis=0) / (result.reach * 1e3) * 100)
        .round(6)
        .tolist(),
        **orientation_columns(result),
        "seconds_last_attempt": round(time.perf_counter() - start, 2),
    }
    write_json(folder / CELL_FILE, row)
    return row


def orientation_columns(result: Evaluation) -> dict[str, list[float]]:
    """Mean, median and 90th percentile of the hand's orientation error (degrees) after each
    move over all held-out trials, counted as the distances are; empty off the grasp envs."""
    if result.orientation_errors is None:
        return {}
    degrees = np.degrees(errors_all_counted(result.orientation_errors))  # (n, moves)
    return {
        "mean_deg": np.mean(degrees, axis=0).round(5).tolist(),
        "median_deg": np.median(degrees, axis=0).round(5).tolist(),
        "p90_deg": np.percentile(degrees, 90, axis=0).round(5).tolist(),
    }
