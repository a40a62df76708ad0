"""A realistic training trial's cost, counted and timed: renderings of the sensing cameras, the
views drawn in them, physics steps, and the time of each part (physics, sensing, its drawing and
read-back, the rest), per trial of ``train.py``'s loop (``Trainer.train_one``), foveated sensing
and servo moves.

Two arms run side by side in one process, taking turns block by block so that a change in the
machine's load falls on both: ``plain`` (every foveated window rendered, the numpy settle test:
the reference path) and ``default`` (what the envs do). Both train a map of the same seed; their
trials, maps and final simulation states are compared bit for bit. The counters are the scene's
own (:meth:`envs.scene.ArmScene.work_counts`); the times come from wrappers this module puts
around the env's move, its sensor and MuJoCo's drawing and read-back calls while it measures.
"""

from __future__ import annotations

import os
import pickle
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import astuple
from pathlib import Path
from typing import Any, cast

import mujoco
import numpy as np

from envs.harness.training import RunConfig, Trainer
from envs.reach import (
    MAX_SETTLE_TIME,
    MIN_SETTLE_TIME,
    SETTLE_SPEED,
    SETTLE_WINDOW,
    ReachEnv,
    moving,
    moving_numpy,
)
from envs.scene import INTEGRATION_STATE, WorkCounts

#: The envs measured: the reach envs of the two published arms and the grasp env.
ENV_IDS = ("RiacsReach-v0", "PumaReach-v0", "PumaGrasp-v0")
#: The realistic setting.
SETTING = {"sensing": "foveated", "control": "servo"}
ARMS = ("plain", "default")
#: The parts a trial's time is split into; drawing and read-back are parts of sensing.
PARTS = ("physics", "sensing", "drawing", "read_back")
#: MuJoCo's calls that draw a sensing view (scene update, camera, render) and read it back.
DRAW_CALLS = ("mjv_updateScene", "mjv_updateCamera", "mjr_render")
READ_CALLS = ("mjr_readPixels",)
MS_PER_S = 1e3
MM_PER_M = 1e3
US_PER_S = 1e6


def use_plain_path(env: ReachEnv) -> None:
    """Make ``env`` take the reference path: every view drawn (``StereoRig.reuse_renders``
    off), every foveated window rendered (``FoveatedSensing.skip_blind`` off) and the numpy
    settle test."""
    env.stereo.reuse_renders = False
    env.fovea.skip_blind = False
    env.moving = moving_numpy


class Clock:
    """Seconds spent in each of PARTS, summed by the wrappers of :meth:`wrap`."""

    def __init__(self) -> None:
        self.seconds = dict.fromkeys(PARTS, 0.0)

    def wrap(self, function: Callable[..., Any], part: str) -> Callable[..., Any]:
        """``function`` timed into ``part``."""

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                self.seconds[part] += time.perf_counter() - start

        return timed


@contextmanager
def timed_mujoco(current: Callable[[], Clock]) -> Iterator[None]:
    """Time MuJoCo's drawing and read-back calls into ``current()``'s clock while the block
    runs (the sensing renderer calls them through the module); restored after."""
    saved = {name: getattr(mujoco, name) for name in DRAW_CALLS + READ_CALLS}

    def timing(name: str, part: str) -> Callable[..., Any]:
        function = saved[name]

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                current().seconds[part] += time.perf_counter() - start

        return timed

    try:
        for name in DRAW_CALLS:
            setattr(mujoco, name, timing(name, "drawing"))
        for name in READ_CALLS:
            setattr(mujoco, name, timing(name, "read_back"))
        yield
    finally:
        for name, function in saved.items():
            setattr(mujoco, name, function)


class Arm:
    """One arm's trainer, its env timed by a :class:`Clock`, and what it has measured."""

    def __init__(self, name: str, config: RunConfig, out: Path) -> None:
        self.name, self.clock = name, Clock()
        self.trainer = Trainer(config, out)
        env = self.env = cast(ReachEnv, self.trainer.env.unwrapped)
        if name == "plain":
            use_plain_path(env)
        # Instance attributes shadow the methods for this measurement only.
        env._move = self.clock.wrap(env._move, "physics")  # type: ignore[method-assign]
        sensor = env.sensor
        sensor.sense_target = self.clock.wrap(sensor.sense_target, "sensing")  # type: ignore[method-assign]
        sensor.sense_effector = self.clock.wrap(sensor.sense_effector, "sensing")  # type: ignore[method-assign]
        self.start = env.work_counts()  # the initial map's resets are not trials
        self.skipped_start, self.reused_start = env.fovea.skipped, env.stereo.reused
        self.seconds = 0.0
        self.moves = 0
        self.trials: list[bytes] = []

    def run(self, trials: int) -> None:
        start = time.perf_counter()
        for _ in range(trials):
            trial = self.trainer.train_one()
            self.moves += len(trial.commands) + trial.recovery_moves
            self.trials.append(pickle.dumps(astuple(trial)))
        self.seconds += time.perf_counter() - start

    def final_state(self) -> bytes:
        """The trials, the map and the simulation's integration state, as bytes."""
        env = self.env
        state = np.empty(mujoco.mj_stateSize(env.model, INTEGRATION_STATE))
        mujoco.mj_getState(env.model, env.data, state, INTEGRATION_STATE)
        return b"".join(self.trials) + pickle.dumps(self.trainer.som) + state.tobytes()

    def row(self, trials: int) -> dict[str, Any]:
        counts: WorkCounts = self.env.work_counts() - self.start
        seconds = self.clock.seconds
        rest = self.seconds - seconds["physics"] - seconds["sensing"]
        return {
            "arm": self.name,
            "trials": trials,
            "moves_per_trial": self.moves / trials,
            "renders_per_trial": counts.renders / trials,
            "views_per_trial": counts.views / trials,
            "fallbacks_per_trial": counts.fallbacks / trials,
            "windows_skipped_per_trial": (self.env.fovea.skipped - self.skipped_start) / trials,
            "renders_reused_per_trial": (self.env.stereo.reused - self.reused_start) / trials,
            "physics_steps_per_trial": counts.physics_steps / trials,
            "physics_steps_per_move": counts.physics_steps / max(self.moves, 1),
            "ms_per_trial": self.seconds / trials * MS_PER_S,
            **{f"{part}_ms": s / trials * MS_PER_S for part, s in seconds.items()},
            "rest_ms": rest / trials * MS_PER_S,
        }


def settle_test_us(calls: int, seed: int) -> dict[str, float]:
    """µs per call of the settle test, numpy reference and floats, on random speeds of six
    joints (the PUMA's), taking turns in blocks."""
    speeds = np.random.default_rng(seed).normal(0.0, 1e-3, (calls, 6))
    totals = {"numpy": 0.0, "floats": 0.0}
    block = max(calls // 10, 1)
    for first in range(0, calls, block):
        for name, test in (("numpy", moving_numpy), ("floats", moving)):
            start = time.perf_counter()
            for qvel in speeds[first : first + block]:
                test(qvel)
            totals[name] += time.perf_counter() - start
    return {name: seconds / calls * US_PER_S for name, seconds in totals.items()}


def measure(env_id: str, trials: int, block: int, seed: int) -> dict[str, Any]:
    """Both arms on ``env_id``, ``trials`` training trials each in turns of ``block``; one
    row per arm and whether they gave the same trials, map and final state."""
    config = RunConfig.of(env=env_id, trials=trials, seed=seed, **SETTING)
    with tempfile.TemporaryDirectory(prefix="trial_cost-") as scratch:
        arms = [Arm(name, config, Path(scratch) / name) for name in ARMS]
        current = arms[0].clock
        try:
            with timed_mujoco(lambda: current):
                for first in range(0, trials, block):
                    for arm in arms:
                        current = arm.clock
                        arm.run(min(block, trials - first))
            same = arms[0].final_state() == arms[1].final_state()
        finally:
            for arm in arms:
                arm.trainer.close()
    return {"env": env_id, "rows": [arm.row(trials) for arm in arms], "identical": same}


def settle_step(elapsed: np.ndarray, speeds: np.ndarray, speed: float) -> int:
    """The physics step (index) at which a servo move whose steps ended at ``elapsed`` (n,) s
    with greatest joint speeds ``speeds`` (n,) rad/s would end were its settle speed ``speed``
    (rad/s): the rule of ``ReachEnv``'s moves with another threshold (the last step if it never
    settles within them)."""
    slow_since = None
    for i, (t, v) in enumerate(zip(elapsed.tolist(), speeds.tolist(), strict=True)):
        if v >= speed:
            slow_since = None
        elif slow_since is None:
            slow_since = t
        settled = slow_since is not None and t - slow_since >= SETTLE_WINDOW
        if (t >= MIN_SETTLE_TIME and settled) or t >= MAX_SETTLE_TIME:
            return i
    return len(elapsed) - 1


def settle_speeds(env_id: str, trials: int, seed: int, speeds: list[float]) -> dict[str, Any]:
    """What a faster settle rule would save: over ``trials`` training trials (the default
    path), each servo move's physics steps recorded (``ReachEnv.on_physics_step``), and for
    each settle speed of ``speeds`` (rad/s) the steps a move would take and how far (mm) the
    sensed point still moved between that stop and the move's actual end. SETTLE_SPEED itself
    must give every move's own steps (checked: ``matches``)."""
    config = RunConfig.of(env=env_id, trials=trials, seed=seed, **SETTING)
    trace: list[tuple[float, float, np.ndarray]] = []  # elapsed s, max |qvel|, sensed point
    with tempfile.TemporaryDirectory(prefix="settle_speeds-") as scratch:
        trainer = Trainer(config, Path(scratch) / "run")
        env = cast(ReachEnv, trainer.env.unwrapped)
        qvel = env.data.qvel

        def record(elapsed: float) -> None:
            trace.append((elapsed, float(np.max(np.abs(qvel))), env.sensed_point()))

        env.on_physics_step = record
        try:
            for _ in range(trials):
                trainer.train_one()
        finally:
            trainer.close()
    starts = [i for i, (t, _, _) in enumerate(trace) if i == 0 or t <= trace[i - 1][0]]
    moves = [trace[a:b] for a, b in zip(starts, [*starts[1:], len(trace)], strict=True)]
    steps = np.zeros(len(speeds), dtype=int)  # per speed, over the moves
    moved = np.zeros((len(moves), len(speeds)))  # m, per move and speed
    matches = True
    for m, move in enumerate(moves):
        elapsed = np.array([t for t, _, _ in move])
        fastest = np.array([v for _, v, _ in move])
        matches &= settle_step(elapsed, fastest, SETTLE_SPEED) == len(move) - 1
        for j, speed in enumerate(speeds):
            stop = settle_step(elapsed, fastest, speed)
            steps[j] += stop + 1
            moved[m, j] = np.linalg.norm(move[-1][2] - move[stop][2])
    return {
        "env": env_id,
        "moves": len(moves),
        "matches": bool(matches),
        "rows": [
            {
                "settle_speed": speed,
                "steps_per_move": float(steps[j]) / max(len(moves), 1),
                "moved_mm_mean": float(moved[:, j].mean()) * MM_PER_M,
                "moved_mm_max": float(moved[:, j].max()) * MM_PER_M,
            }
            for j, speed in enumerate(speeds)
        ],
    }


def format_settle(results: dict[str, Any]) -> str:
    lines = [
        f"{results['env']}: {results['moves']} servo moves; the rule at {SETTLE_SPEED} rad/s "
        f"{'gives' if results['matches'] else 'DOES NOT give'} every move's own steps",
        f"{'settle speed rad/s':>18} {'steps/move':>10} {'moved after, mean mm':>20} {'max mm':>7}",
    ]
    for r in results["rows"]:
        lines.append(
            f"{r['settle_speed']:>18g} {r['steps_per_move']:>10.1f} "
            f"{r['moved_mm_mean']:>20.4f} {r['moved_mm_max']:>7.3f}"
        )
    return "\n".join(lines)


def benchmark(env_ids: tuple[str, ...], trials: int, block: int, seed: int) -> dict[str, Any]:
    """:func:`measure` for each env, the settle test's cost, the machine and its load."""
    load_before = os.getloadavg()
    envs_ = [measure(env_id, trials, block, seed) for env_id in env_ids]
    return {
        "setting": SETTING,
        "seed": seed,
        "envs": envs_,
        "settle_test_us": settle_test_us(100_000, seed),
        "cores": os.cpu_count(),
        "load_average_before": [round(x, 2) for x in load_before],
        "load_average_after": [round(x, 2) for x in os.getloadavg()],
    }


def format_table(results: dict[str, Any]) -> str:
    lines = [
        f"A training trial's cost ({results['setting']['sensing']} sensing, "
        f"{results['setting']['control']} moves, seed {results['seed']}); load average "
        f"{results['load_average_before'][0]} before, {results['load_average_after'][0]} after, "
        f"{results['cores']} cores",
        f"{'env':<14} {'arm':<8} {'moves':>5} {'renders':>7} {'views':>6} {'reused':>6} "
        f"{'skipped':>7} "
        f"{'steps':>6} {'/move':>6} {'ms':>6} {'physics':>7} {'sensing':>7} {'drawing':>7} "
        f"{'read':>6} {'rest':>6}",
    ]
    for env in results["envs"]:
        for r in env["rows"]:
            lines.append(
                f"{env['env']:<14} {r['arm']:<8} {r['moves_per_trial']:>5.2f} "
                f"{r['renders_per_trial']:>7.2f} {r['views_per_trial']:>6.2f} "
                f"{r['renders_reused_per_trial']:>6.2f} "
                f"{r['windows_skipped_per_trial']:>7.2f} {r['physics_steps_per_trial']:>6.1f} "
                f"{r['physics_steps_per_move']:>6.1f} {r['ms_per_trial']:>6.2f} "
                f"{r['physics_ms']:>7.2f} {r['sensing_ms']:>7.2f} {r['drawing_ms']:>7.2f} "
                f"{r['read_back_ms']:>6.2f} {r['rest_ms']:>6.2f}"
            )
        same = "the same trials, map and final state" if env["identical"] else "DIFFERENT trials"
        lines.append(f"{env['env']:<14} both arms: {same}")
    us = results["settle_test_us"]
    lines.append(
        f"settle test per physics step: numpy {us['numpy']:.2f} µs, floats {us['floats']:.2f} µs"
    )
    return "\n".join(lines)
