"""Running PumaTrack episodes with a path tracker: tracking, learning while tracking, and
evaluation; and the exact reference :func:`exact_inverse_jacobian`."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from learners.natenet import NATEnet, PathTracker
from models.paths import Path
from models.puma560.kinematics import jacobian
from models.rotations import orientation_error


def exact_inverse_jacobian(theta: np.ndarray) -> np.ndarray:
    """J(θ)⁻¹ (6, 6) of the tcp in frame 0 (= world axes), by ``np.linalg.solve``."""
    return np.linalg.solve(jacobian(theta), np.eye(6))


def pose_delta(p0: np.ndarray, R0: np.ndarray, p1: np.ndarray, R1: np.ndarray) -> np.ndarray:
    """Pose change (6,): position change (m) and the rotation vector of R1·R0ᵀ (rad, world)."""
    return np.concatenate([p1 - p0, orientation_error(R1, R0)])


@dataclass
class EpisodeResult:
    """One tracked path: per-step errors, ground-truth TCP positions, learning counts."""

    position_errors: np.ndarray  # (n,) m
    orientation_errors: np.ndarray  # (n,) rad
    tcp_positions: np.ndarray  # (n+1, 3) m, ground truth
    path: Path
    command_time: float  # s, mean wall time of one controller command
    step_time: float  # s, mean wall time of one whole step (command, env step, learning)
    allocations: int = 0
    frames: list[np.ndarray] | None = None


def track_episode(
    env: gym.Env,
    tracker: PathTracker,
    options: dict | None = None,
    seed: int | None = None,
    learner: NATEnet | None = None,
    exploration: float = 0.0,
    rng: np.random.Generator | None = None,
    record: bool = False,
) -> EpisodeResult:
    """Run one path with ``tracker`` (a ``learners.natenet.PathTracker``).

    With a ``learner`` (a NATEnet), every move teaches it: the observed pair (Δθ, Δx) of joint
    change and sensed pose change is learnt at the move's midpoint configuration. ``exploration``
    adds Gaussian joint noise (rad, std) to each command, from ``rng``, so that the moves excite
    all directions. ``record`` keeps ``env.render()`` frames.
    """
    base = env.unwrapped
    episode_start = time.perf_counter()
    obs, info = env.reset(seed=seed, options=options)
    pos_err, ori_err, allocations, command_time = [], [], 0, 0.0
    frames = [env.render()] if record else None
    done = False
    while not done:
        theta, p, R = obs["joints"], obs["tcp_pos"], obs["tcp_rot"].reshape(3, 3)
        error = pose_delta(p, R, obs["target_pos"], obs["target_rot"].reshape(3, 3))
        start = time.perf_counter()
        action = tracker.command(theta, error, obs["target_vel"], base.dt)
        command_time += time.perf_counter() - start
        if exploration > 0.0:
            action = action + exploration * rng.standard_normal(6)
        seen_before = info["visible"]
        obs, _, terminated, truncated, info = env.step(action)
        done = terminated or truncated
        if learner is not None and seen_before and info["visible"]:
            dtheta = obs["joints"] - theta
            dx = pose_delta(p, R, obs["tcp_pos"], obs["tcp_rot"].reshape(3, 3))
            if np.any(dx):
                midpoint = (theta + obs["joints"]) / 2.0
                allocations += learner.learn(midpoint[: learner.input_dim], dtheta, dx).allocated
        pos_err.append(info["position_error"])
        ori_err.append(info["orientation_error"])
        if record:
            frames.append(env.render())
    n = len(pos_err)
    step_time = (time.perf_counter() - episode_start) / n
    return EpisodeResult(
        np.array(pos_err),
        np.array(ori_err),
        np.array(base.trace),
        base.path,
        command_time / n,
        step_time,
        allocations,
        frames,
    )


def train_on_paths(
    env: gym.Env,
    net: NATEnet,
    seeds,
    exploration: float,
    rng: np.random.Generator,
    gain: float = 1.0,
) -> dict[str, np.ndarray]:
    """Learn while tracking one path per seed (``env.reset(seed=...)``) with exploration noise.

    Returns:
        ``steps`` (learning steps after each path), ``nodes`` (node count after each path) and
        ``joint_lower``, ``joint_upper`` (6,): the joint box of the paths' configurations (rad).
    """
    tracker = PathTracker.from_net(net, gain)
    steps, nodes, lower, upper = [], [], [], []
    for seed in seeds:
        res = track_episode(
            env, tracker, seed=int(seed), learner=net, exploration=exploration, rng=rng
        )
        steps.append(net.steps)
        nodes.append(net.n_nodes)
        lower.append(res.path.joints.min(axis=0))
        upper.append(res.path.joints.max(axis=0))
    return {
        "steps": np.array(steps),
        "nodes": np.array(nodes),
        "joint_lower": np.min(lower, axis=0),
        "joint_upper": np.max(upper, axis=0),
    }


def evaluate(env: gym.Env, tracker: PathTracker, seeds) -> dict[str, Any]:
    """Track one path per seed without learning.

    Returns:
        ``position_mm``, ``orientation_deg``: (paths, steps) errors; ``command_time`` and
        ``step_time``: mean seconds per controller command and per whole step; ``results``:
        the :class:`EpisodeResult` of each path.
    """
    results = [track_episode(env, tracker, seed=int(s)) for s in seeds]
    return {
        "position_mm": np.array([r.position_errors for r in results]) * 1e3,
        "orientation_deg": np.degrees(np.array([r.orientation_errors for r in results])),
        "command_time": float(np.mean([r.command_time for r in results])),
        "step_time": float(np.mean([r.step_time for r in results])),
        "results": results,
    }
