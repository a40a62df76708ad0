"""Training a learner on a reach env, trial by trial, with held-out evaluations and checkpoints
from which a run continues exactly as if it had never stopped."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from envs.evaluation import evaluate
from envs.reach import IMAGE_HEIGHT, IMAGE_WIDTH
from envs.trials import learn_from, run_trial
from learners.persistence import CheckpointError, write_atomic
from learners.som import VisuomotorSOM
from models.arms import arm_kinematics

MAP_FILE, STATE_FILE, METRICS_FILE = "som.npz", "trainer.json", "metrics.jsonl"
#: The held-out targets come from the env seeded with seed + EVAL_SEED_OFFSET, never trained on.
EVAL_SEED_OFFSET = 10_000
#: Weight of the newest trial in the running errors shown on the progress bar.
RUNNING_WEIGHT = 0.02


@dataclass(frozen=True)
class RunConfig:
    """Everything that defines a training run (stored in the checkpoint)."""

    env: str = "RiacsReach-v0"
    sensing: str = "project"
    control: str = "kinematic"
    seed: int = 0
    trials: int = 10_000
    lattice: tuple[int, ...] = (12, 7, 4)
    rule: str = "mrs"
    protocol: str = "mrs"  # or "brause": Brause's coarse move, fine move (3.7), learning
    keep_arm: bool = False
    eval_every: int = 1000
    eval_trials: int = 200
    fine_moves: int = 2
    refine: bool = True
    image_size: tuple[int, int] = (IMAGE_HEIGHT, IMAGE_WIDTH)  # sensing images, px

    def __post_init__(self) -> None:  # tuples also when read back from JSON lists
        object.__setattr__(self, "lattice", tuple(int(n) for n in self.lattice))
        object.__setattr__(self, "image_size", tuple(int(n) for n in self.image_size))

    def make_env(self, seed_offset: int = 0) -> gym.Env:
        env = gym.make(
            self.env, sensing=self.sensing, control=self.control, image_size=self.image_size
        )
        env.reset(seed=self.seed + seed_offset)
        return env


def initial_map(config: RunConfig, env: gym.Env) -> VisuomotorSOM:
    """A fresh map for ``env``: w spread over the box of the workspace's image, every θ_r at
    the robot's ready pose (the sensed point at the workspace centre, in view of both cameras).

    The box comes from projecting workspace points drawn with a generator of the run's seed.
    """
    base = env.unwrapped
    rng = np.random.default_rng(config.seed)
    pixels = base.stereo.project(base.spec_robot.workspace.sample(rng, 2000))
    return VisuomotorSOM(
        base.joint_lower,
        base.joint_upper,
        lattice=config.lattice,
        rule=config.rule,
        protocol=config.protocol,
        refine=config.refine,
        t_max=config.trials,
        rng=rng,
        input_low=pixels.min(axis=0),
        input_high=pixels.max(axis=0),
        theta_init=arm_kinematics(base.robot, base.joints).ready,
    )


class Trainer:
    """Runs ``config.trials`` training trials, evaluating every ``eval_every`` trials.

    Args:
        config: the run; out: folder for the checkpoint (som.npz, trainer.json) and
            metrics.jsonl.
    """

    def __init__(self, config: RunConfig, out: Path) -> None:
        self.config, self.out = config, Path(out)
        self.env = config.make_env()
        self.som = initial_map(config, self.env)
        self.trial = 0
        self.running = {"coarse_mm": float("nan"), "fine_mm": float("nan")}

    # -- checkpoints ---------------------------------------------------------------------------

    @classmethod
    def resume(cls, out: Path) -> Trainer:
        """Continue the run saved in ``out``."""
        state_path = Path(out) / STATE_FILE
        if not state_path.is_file():
            raise CheckpointError(f"{state_path}: no checkpoint to resume; train without --resume")
        state = json.loads(state_path.read_text())
        config = RunConfig(**{**state["config"], "lattice": tuple(state["config"]["lattice"])})
        trainer = cls(config, out)
        trainer.som = VisuomotorSOM.load(Path(out) / MAP_FILE)
        seen = trainer.som.t + sum(trainer.som.skipped.values())
        if seen != state["learn_calls"]:
            raise CheckpointError(
                f"{out}: som.npz has {seen} trials but trainer.json {state['learn_calls']}; the "
                "two files are from different moments (interrupted while saving?); retrain"
            )
        trainer.trial, trainer.running = state["trial"], state["running"]
        base = trainer.env.unwrapped
        base.np_random.bit_generator.state = state["env_rng"]
        for name in ("qpos", "qvel", "ctrl"):
            getattr(base.data, name)[:] = state["arm"][name]
        trainer._truncate_metrics()
        return trainer

    def save(self) -> None:
        """som.npz, then trainer.json (both atomic); trainer.json counts the map's trials."""
        self.som.save(self.out / MAP_FILE)
        base = self.env.unwrapped
        state = {
            "config": asdict(self.config),
            "trial": self.trial,
            "learn_calls": self.som.t + sum(self.som.skipped.values()),
            "running": self.running,
            "env_rng": base.np_random.bit_generator.state,
            "arm": {n: getattr(base.data, n).tolist() for n in ("qpos", "qvel", "ctrl")},
        }
        write_atomic(self.out / STATE_FILE, lambda f: f.write(json.dumps(state, indent=1).encode()))

    def _truncate_metrics(self) -> None:
        """Drop evaluations logged after the checkpoint, so the file matches an unbroken run."""
        path = self.out / METRICS_FILE
        if path.is_file():
            rows = [
                r for r in path.read_text().splitlines() if json.loads(r)["trial"] <= self.trial
            ]
            write_atomic(path, lambda f: f.write("".join(r + "\n" for r in rows).encode()))

    # -- the loop ------------------------------------------------------------------------------

    def run(
        self,
        checkpoint_every: int = 1000,
        progress: Callable[[int, dict[str, float]], None] | None = None,
    ) -> None:
        """Train until ``config.trials``; checkpoint every ``checkpoint_every`` trials, at the
        end, and on KeyboardInterrupt (then re-raised)."""
        self.out.mkdir(parents=True, exist_ok=True)
        if self.trial == 0 and not (self.out / METRICS_FILE).exists():
            self._log(self.held_out())
        try:
            while self.trial < self.config.trials:
                self.train_one()
                if self.trial % self.config.eval_every == 0 or self.trial == self.config.trials:
                    self._log(self.held_out())
                if self.trial % checkpoint_every == 0:
                    self.save()
                if progress is not None:
                    progress(self.trial, self.running)
        except KeyboardInterrupt:
            self.save()
            raise
        self.save()

    def train_one(self) -> None:
        trial = run_trial(
            self.env, self.som, fine_moves=1, keep_arm=self.config.keep_arm, explore=True
        )
        learn_from(self.som, trial)
        self.trial += 1
        for key, k in (("coarse_mm", 0), ("fine_mm", 1)):
            if len(trial.distances) > k:
                new = trial.distances[k] * 1e3
                old = self.running[key]
                self.running[key] = new if np.isnan(old) else old + RUNNING_WEIGHT * (new - old)

    def held_out(self) -> dict[str, Any]:
        """Evaluate on the fixed held-out targets (without learning)."""
        env = self.config.make_env(EVAL_SEED_OFFSET)
        try:
            result = evaluate(env, self.som, self.config.eval_trials, self.config.fine_moves)
        finally:
            env.close()
            self.som.reset()
        summary = result.summary()
        del summary["microseconds_per_query"]  # wall time: would make reruns differ
        return {"trial": self.trial, "learned": self.som.t, **summary}

    def _log(self, row: dict[str, Any]) -> None:
        with open(self.out / METRICS_FILE, "a") as f:
            f.write(json.dumps(row) + "\n")

    def close(self) -> None:
        self.env.close()
