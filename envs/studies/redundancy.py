"""Redundancy of a map trained on a 7-joint arm: which solution each neuron chose, how smoothly it
varies across the lattice, and whether any command left the joint ranges.

The redundant angle measured is the arm's **swivel (elbow) angle** ψ (:func:`swivel_angle`): the
angle, about the shoulder–wrist line S→W, of the plane through shoulder S, elbow E and wrist W,
measured from the plane through that line and the vertical, positive by the right-hand rule
about S→W; ψ = 0 puts the elbow above the line in the vertical plane. Rotating the arm's
shoulder-to-wrist part about S→W (joints 1-3 with the elbow joint fixed) changes ψ by the angle
turned and moves neither S nor W.

The points are origins of joint frames of the robot's DH chain (:func:`models.dh_arm.joint_frames`;
the joints are the registry entry's ``swivel_joints``, :class:`envs.robots.RobotSpec`). On the
Franka-Panda-type chain (Craig's modified convention, ``models/panda/dh.toml``): S is the
origin of joint 2's frame (axes 1, 2 and 3 meet there), E that of joint 4's (on the elbow axis,
0.0825 m off the upper arm's axis), W that of joint 6's (axes 5 and 6 meet there; it is also
joint 5's origin, and joint 7's axis passes 0.088 m off).
In the generated MJCF those are the origins of the bodies ``link2``, ``link4`` and ``link6``.
The map never sees these kinematics; only this evaluation does.

:func:`measure` takes a trained run: ψ and the joint angles of every neuron's θ_r, their largest,
median and 99th-percentile jumps between lattice neighbours (±1 along each lattice axis), and the
held-out evaluation (:func:`envs.harness.evaluation.evaluate`) with every command recorded and
counted against the joint ranges. The figure is :mod:`envs.studies.redundancy_plot`.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from envs.harness.checkpoint import checkpoint_path
from envs.harness.evaluation import Evaluation, Wrapped, evaluate
from envs.harness.streams import seed_env
from envs.harness.training import Trainer
from envs.robots import ROBOTS, robot_of_env
from learners.base import Controller
from learners.som.controller import VisuomotorSOM
from models.dh_arm import DHArm, joint_frames, tcp_position

#: The direction the swivel angle's reference plane contains besides S→W (world, up).
VERTICAL = (0.0, 0.0, 1.0)
#: The high percentile of the neighbour jumps reported beside the largest and the median.
PERCENTILE = 99.0


class RedundancyError(ValueError):
    """A run this study cannot measure: its robot has no swivel angle here, or it does not
    control all of the arm's joints."""


def swivel_angle(
    shoulder: np.ndarray, elbow: np.ndarray, wrist: np.ndarray, up: tuple[float, ...] = VERTICAL
) -> np.ndarray:
    """The swivel angle ψ (...,), rad in (-π, π], of points (..., 3) (module docstring): the
    angle about S→W from the projection of ``up`` to that of E − S, both onto the plane normal
    to S→W. Undefined (NaN) where S→W is along ``up`` or E lies on the line."""
    axis = np.asarray(wrist, dtype=float) - shoulder  # (..., 3)
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    up_ = np.asarray(up, dtype=float)

    def across(v: np.ndarray) -> np.ndarray:  # v's part normal to the axis, made unit
        v = v - np.sum(v * axis, axis=-1, keepdims=True) * axis
        norm = np.linalg.norm(v, axis=-1, keepdims=True)
        return np.where(norm > 1e-12, v / np.where(norm > 1e-12, norm, 1.0), np.nan)

    ref, elb = across(np.broadcast_to(up_, axis.shape)), across(np.asarray(elbow) - shoulder)
    return np.arctan2(np.sum(axis * np.cross(ref, elb), axis=-1), np.sum(ref * elb, axis=-1))


def swivel_robots() -> list[str]:
    """The registry's robots that name their shoulder, elbow and wrist joints."""
    return [name for name, spec in ROBOTS.items() if spec.swivel_joints is not None]


def swivel_joints(robot: str) -> tuple[int, int, int]:
    """The joints whose frame origins are ``robot``'s shoulder, elbow and wrist."""
    joints = ROBOTS[robot].swivel_joints
    assert joints is not None, robot  # dh_arm_of refused the robot
    return joints


def dh_arm_of(robot: str) -> DHArm:
    """The DH arm of a robot generated from its table (``models/<robot>/``'s ``TABLE``), with
    its shoulder, elbow and wrist in its registry entry; RedundancyError naming what to
    add else."""
    if robot not in ROBOTS or ROBOTS[robot].swivel_joints is None:
        raise RedundancyError(
            f"no swivel angle for robot {robot!r}: it is defined for {', '.join(swivel_robots())}; "
            "give the robot's shoulder, elbow and wrist joints as swivel_joints in its RobotSpec "
            "(envs/robots.py)"
        )
    return importlib.import_module(f"models.{robot}").TABLE


def arm_points(arm: DHArm, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shoulder, elbow and wrist (..., 3), world m, of all joint angles θ (..., n), rad."""
    axes = joint_frames(arm, theta)[0]  # (..., n, 4, 4)
    s, e, w = swivel_joints(arm.name)
    return axes[..., s - 1, :3, 3], axes[..., e - 1, :3, 3], axes[..., w - 1, :3, 3]


def arm_swivel(arm: DHArm, theta: np.ndarray) -> np.ndarray:
    """The swivel angle (...,), rad, of joint angles θ (..., n), rad."""
    return swivel_angle(*arm_points(arm, theta))


def wrapped(angle: np.ndarray) -> np.ndarray:
    """Angles (rad) brought into [-π, π)."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def neighbour_steps(values: np.ndarray, lattice: tuple[int, ...], circular: bool) -> np.ndarray:
    """|differences| between lattice neighbours (±1 along each axis), all pairs once.

    Args:
        values: one value per neuron (N,), C order over ``lattice``, or (N, K) for K at once.
        circular: the values are angles on a circle (the difference wrapped into [-π, π)).
    Returns:
        (pairs,) or (pairs, K).
    """
    grid = np.asarray(values, dtype=float).reshape(*lattice, -1)
    steps = []
    for a in range(len(lattice)):
        d = np.diff(grid, axis=a)
        steps.append(np.abs(wrapped(d) if circular else d).reshape(-1, grid.shape[-1]))
    out = np.concatenate(steps)  # (pairs, K)
    return out if np.ndim(values) > 1 else out[:, 0]


def step_figures(steps: np.ndarray) -> dict[str, float]:
    """Largest, median and :data:`PERCENTILE` th percentile of neighbour steps (pairs,), in
    degrees (steps in rad)."""
    deg = np.degrees(steps)
    return {
        "max_deg": round(float(deg.max()), 3),
        "median_deg": round(float(np.median(deg)), 3),
        "p99_deg": round(float(np.percentile(deg, PERCENTILE)), 3),
    }


def outside_ranges(commands: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> int:
    """How many commands (M, J), rad, have a joint outside [lower, upper]."""
    c = np.asarray(commands, dtype=float)
    return int(np.sum(np.any((c < lower) | (c > upper), axis=-1)))


def at_limits(commands: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> int:
    """How many commands (M, J), rad, have a joint exactly at a range end (a clipped one)."""
    c = np.asarray(commands, dtype=float)
    return int(np.sum(np.any((c == lower) | (c == upper), axis=-1)))


class Recording(Wrapped):
    """``inner`` whose commands are kept: ``trials[i][k]`` is move k (0 coarse) of trial i."""

    def __init__(self, inner: Controller) -> None:
        super().__init__(inner)
        self.trials: list[list[np.ndarray]] = []

    def reset(self) -> None:
        self.trials.append([])
        self.inner.reset()

    def act(self, u, v=None, explore=False):
        command = super().act(u, v, explore)
        self.trials[-1].append(np.array(command, dtype=float))
        return command


@dataclass
class Redundancy:
    """What :func:`measure` found for one trained run.

    Attributes:
        env, sensing, control, lattice: the run's env id, settings and lattice shape.
        theta: the neurons' joint angles (N, J), rad, C order over the lattice.
        swivel: their swivel angles (N,), rad; tcp: their tcp positions (N, 3), world m.
        evaluation: the held-out evaluation.
        commands: every held-out command (M, J), rad; moves: its move (M,) int, 0 coarse.
        target_pos: each held-out trial's target (n, 3), world m; final_swivel: the swivel of
            each trial's last command (n,), rad; fine_turn: how far the fine moves turned it
            from the coarse command's (n,), rad.
        lower, upper: the env's joint ranges (J,), rad.
    """

    env: str
    sensing: str
    control: str
    lattice: tuple[int, ...]
    theta: np.ndarray
    swivel: np.ndarray
    tcp: np.ndarray
    evaluation: Evaluation
    commands: np.ndarray
    moves: np.ndarray
    target_pos: np.ndarray
    final_swivel: np.ndarray
    fine_turn: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    def summary(self) -> dict[str, object]:
        """JSON-ready: the neighbour jumps of ψ and of each joint (degrees), ψ's range over the
        neurons, the commands outside the joint ranges and at a range end (all, coarse, fine),
        how far the fine moves turned ψ, and the evaluation's summary."""
        joint_steps = neighbour_steps(self.theta, self.lattice, circular=False)  # (pairs, J)
        fine = self.moves > 0
        commands = {}
        for name, pick in (("all", slice(None)), ("coarse", ~fine), ("fine", fine)):
            c = self.commands[pick]
            commands[name] = {
                "commands": len(c),
                "outside_ranges": outside_ranges(c, self.lower, self.upper),
                "at_a_limit": at_limits(c, self.lower, self.upper),
            }
        swivel_deg = np.degrees(self.swivel)
        turn_deg = np.degrees(np.abs(self.fine_turn))
        return {
            "env": self.env,
            "sensing": self.sensing,
            "control": self.control,
            "lattice": list(self.lattice),
            "neighbour_pairs": len(joint_steps),
            "swivel_jumps": step_figures(neighbour_steps(self.swivel, self.lattice, True)),
            "swivel_range_deg": [round(float(x), 3) for x in (swivel_deg.min(), swivel_deg.max())],
            "joint_jumps": [step_figures(joint_steps[:, j]) for j in range(joint_steps.shape[1])],
            "commands": commands,
            "fine_turn_deg": {
                "max": round(float(turn_deg.max()), 3),
                "p99": round(float(np.percentile(turn_deg, PERCENTILE)), 3),
            },
            "evaluation": self.evaluation.summary(),
        }


def measure(run: Path, targets: int, evaluation_set: int, fine_moves: int = 2) -> Redundancy:
    """The redundancy of the map trained in ``run`` (a ``train.py`` folder), with ``targets``
    held-out targets of the evaluation stream's set ``evaluation_set`` in the run's setting
    (as ``evaluate.py --run RUN --seed SET`` draws them).

    Raises:
        RedundancyError: the run's robot has no swivel angle here (:func:`dh_arm_of`), the
            run does not control all of its joints, or no held-out target was seen.
        CheckpointError: no run in ``run``, or a damaged one.
    """
    config = Trainer.stored_config(run)
    arm = dh_arm_of(robot_of_env(config.env))
    som = VisuomotorSOM.load(checkpoint_path(run))
    env = config.make_env("evaluation")
    base: Any = env.unwrapped  # a ReachEnv
    try:
        if base.joints != arm.n:
            raise RedundancyError(
                f"{run} controls {base.joints} of the arm's {arm.n} joints; the swivel "
                "angle needs a run on all of them"
            )
        seed_env(env, evaluation_set, "evaluation")
        recording = Recording(som)
        result = evaluate(env, recording, targets, fine_moves)
        lower, upper = base.joint_lower.copy(), base.joint_upper.copy()
    finally:
        env.close()
    made = [trial for trial in recording.trials if trial]  # a target not seen: no command
    if not made:
        raise RedundancyError(f"the cameras saw none of the {targets} held-out targets of {run}")
    commands = np.array([c for trial in made for c in trial])  # (M, J)
    moves = np.array([k for trial in made for k in range(len(trial))])
    first, last = (np.array([trial[i] for trial in made]) for i in (0, -1))
    final = arm_swivel(arm, last)
    seen = np.array([bool(trial) for trial in recording.trials])
    return Redundancy(
        env=config.env,
        sensing=config.sensing,
        control=config.control,
        lattice=tuple(som.config.lattice),
        theta=som.theta.copy(),
        swivel=arm_swivel(arm, som.theta),
        tcp=tcp_position(arm, som.theta),
        evaluation=result,
        commands=commands,
        moves=moves,
        target_pos=result.target_pos[seen],
        final_swivel=final,
        fine_turn=wrapped(final - arm_swivel(arm, first)),
        lower=lower,
        upper=upper,
    )
