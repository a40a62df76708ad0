"""The pose task on the arms generated from DH tables (``Ur5eGrasp-v0``, ``PandaGrasp-v0``):
their hand markers against the DH forward kinematics, the numerical pose IK against it, objects
reachable by construction, the env under Gymnasium's checker, a short training of the
hierarchical map, and the one-line refusals."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (GL back-end before mujoco; registers the ids)
import models
from envs.grasp import GraspEnv
from envs.harness.training import METRICS_FILE, RunConfig, Trainer, initial_grasp_map
from envs.robots import GENERATED_GRASP, ROBOTS, RobotSpec, RobotSpecError
from models.dh_arm import DHTableError, joint_frames, parse_table, read_table
from models.dh_grasp import tool_jacobian, tool_poses
from models.dh_mjcf import scene_grasp_xml
from models.marker_frame import marker_points, orientation_angle
from models.numeric_ik import solve_poses
from models.robot_model import robot_model

ROOT = Path(__file__).resolve().parents[1]
GENERATED = {"ur5e": "Ur5eGrasp-v0", "panda": "PandaGrasp-v0"}
TOL = 1e-9  # m and rad


def _table(robot: str):
    return read_table(ROOT / "models" / robot / "dh.toml")


@pytest.mark.parametrize("robot", GENERATED)
def test_the_hand_markers_are_the_marker_frame_at_the_dh_tcp(robot):
    arm = _table(robot)
    model = models.load_model(robot, scene_file="scene_grasp.xml")
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    names = [f"hand_marker_{c}" for c in ("yellow", "cyan", "magenta")]
    for _ in range(5):
        q = rng.uniform(arm.lower, arm.upper)
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        seen = np.array([data.geom(n).xpos for n in names])  # (3, 3)
        expected = marker_points(joint_frames(arm, q)[1])  # independent: the DH chain
        assert np.abs(seen - expected).max() <= TOL


@pytest.mark.parametrize("robot", GENERATED)
def test_the_shipped_grasp_scene_is_what_the_generator_writes(robot):
    text = (ROOT / "models" / robot / "scene_grasp.xml").read_text()
    assert text == scene_grasp_xml(_table(robot))


def test_the_tool_jacobian_is_the_finite_difference_of_the_tool_pose():
    arm = _table("ur5e")
    theta = np.random.default_rng(1).uniform(arm.lower, arm.upper)
    step = 1e-6
    numeric = np.zeros((6, arm.n))
    for i in range(arm.n):
        d = np.zeros(arm.n)
        d[i] = step
        after, before = tool_poses(arm, theta + d), tool_poses(arm, theta - d)
        numeric[:3, i] = (after[:3, 3] - before[:3, 3]) / (2 * step)
        turn = after[:3, :3] @ before[:3, :3].T  # small rotation: its axis-angle / 2 step
        numeric[3:, i] = np.array([turn[2, 1] - turn[1, 2], turn[0, 2] - turn[2, 0],
                                   turn[1, 0] - turn[0, 1]]) / 2 / (2 * step)  # fmt: skip
    np.testing.assert_allclose(tool_jacobian(arm, theta), numeric, atol=1e-8)


@pytest.mark.parametrize("robot", GENERATED)
def test_the_numerical_pose_ik_reaches_poses_of_the_forward_kinematics(robot):
    arm = _table(robot)
    task = robot_model(robot).grasp
    low, high = task.joint_box(None)
    rng = np.random.default_rng(2)
    truth = rng.uniform(low, high, size=(6, arm.n))
    goals = tool_poses(arm, truth)  # (6, 4, 4)
    start = np.broadcast_to(task.ready, truth.shape)
    theta, reached = solve_poses(
        lambda q: tool_poses(arm, q), lambda q: tool_jacobian(arm, q), goals, start, low, high
    )
    assert reached.all() and np.all((theta >= low) & (theta <= high))
    found = tool_poses(arm, theta)
    assert np.abs(found[:, :3, 3] - goals[:, :3, 3]).max() <= TOL
    assert orientation_angle(found[:, :3, :3], goals[:, :3, :3]).max() <= TOL
    # a pose beyond the reach is reported as not reached, the joints still in the box
    far = goals[:1].copy()
    far[0, :3, 3] *= 10.0
    theta, reached = solve_poses(lambda q: tool_poses(arm, q), lambda q: tool_jacobian(arm, q),
                                 far, start[:1], low, high)  # fmt: skip
    assert not reached[0] and np.all((theta >= low) & (theta <= high))


@pytest.mark.parametrize("robot", GENERATED)
def test_drawn_objects_are_grasped_by_the_pose_ik_through_the_env(robot):
    env = GraspEnv(robot=robot, sensing="project", control="kinematic")
    task = env.task
    for seed in range(3):
        env.reset(seed=seed)
        target = env.target_pose()
        # the drawn joints grasp it (forward kinematics), inside the action box
        drawn = task.forward(env.target_joints)
        assert np.abs(drawn[:3, 3] + task.base - target[:3, 3]).max() <= TOL
        assert np.all(env.target_joints >= env.action_lower)
        assert np.all(env.target_joints <= env.action_upper)
        goal = target.copy()
        goal[:3, 3] -= task.base
        theta, reached = task.pose_ik(goal, task.ready, env.action_lower, env.action_upper)
        assert reached
        _, _, _, _, info = env.step(theta)
        assert info["distance"] <= TOL and info["orientation_error"] <= TOL
        assert info["is_success"]
    env.close()


@pytest.mark.parametrize("env_id", GENERATED.values())
def test_the_env_passes_gymnasium_s_checker(env_id):
    env = gym.make(env_id, sensing="project", control="kinematic")
    check_env(env.unwrapped, skip_render_check=True)
    assert env.unwrapped.action_space.shape == (robot_model(env.unwrapped.robot).grasp.n_joints,)
    env.close()


@pytest.mark.parametrize("env_id", GENERATED.values())
def test_the_map_starts_at_the_task_s_taught_pose_inside_the_action_box(env_id):
    config = RunConfig.of(env=env_id, trials=10, lattice=(2, 2, 2), orientation_lattice=(2,))
    env = config.make_env()
    base = env.unwrapped
    som = initial_grasp_map(config, env)
    ready = robot_model(base.robot).grasp.ready
    np.testing.assert_allclose(som.theta, np.broadcast_to(ready, som.theta.shape), atol=1e-9)
    np.testing.assert_array_equal(som.lower, base.action_lower)  # what the env executes
    np.testing.assert_array_equal(som.upper, base.action_upper)
    assert np.all(base.action_upper - base.action_lower < base.joint_upper - base.joint_lower)
    env.close()
    puma = gym.make("PumaGrasp-v0", sensing="project", control="kinematic").unwrapped
    lower, upper = puma.learner_bounds()  # the PUMA's maps keep its joint ranges
    np.testing.assert_array_equal(lower, puma.joint_lower)
    np.testing.assert_array_equal(upper, puma.joint_upper)


def test_a_short_training_improves_the_map_on_the_same_held_out_objects(tmp_path):
    config = RunConfig.of(env="Ur5eGrasp-v0", trials=240, lattice=(3, 3, 2),
                          orientation_lattice=(2,), eval_every=240, eval_trials=30,
                          fine_moves=2, seed=0)  # fmt: skip
    trainer = Trainer(config, tmp_path)
    try:
        trainer.run(checkpoint_every=1000)
    finally:
        trainer.close()
    rows = [json.loads(r) for r in (tmp_path / METRICS_FILE).read_text().splitlines()]
    assert [r["trial"] for r in rows] == [0, 240]  # the untrained map, then the trained one
    assert rows[-1]["mean_mm"][-1] < 0.2 * rows[0]["mean_mm"][-1]
    assert rows[-1]["mean_deg"][-1] < 0.2 * rows[0]["mean_deg"][-1]


def test_a_robot_without_a_pose_task_is_refused_in_one_line():
    with pytest.raises(ValueError, match="robot 'riacs' has no grasp task") as error:
        gym.make("PumaGrasp-v0", robot="riacs")
    assert "\n" not in str(error.value)
    with pytest.raises(RobotSpecError, match="has no pose task") as error:
        RobotSpec(model="riacs", title="x", short="x", reach_env="X-v0", sensed={3: "tcp"},
                  markers={3: "marker_tcp"}, tool_axes={"tcp": (0.0, 1.0, 0.0)},
                  grasp=GENERATED_GRASP, grasp_env="XGrasp-v0")  # fmt: skip
    assert "\n" not in str(error.value)
    assert ROBOTS["riacs"].grasp is None


def test_a_joint_box_arm_takes_no_orientation_range_in_one_line():
    with pytest.raises(ValueError, match="leave orientations out") as error:
        gym.make("Ur5eGrasp-v0", orientations="yaw:90,tilt:45")
    assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match="leave orientations out"):
        RunConfig.of(env="Ur5eGrasp-v0", orientations="ball:30")
    run = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "train.py"), "--env", "Ur5eGrasp-v0",
         "--orientations", "ball:30", "--trials", "1", "--out", "/nonexistent/never"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert run.returncode != 0 and "leave orientations out" in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize(
    "grasp, message",
    [
        ({"joint_box": [0.1, 0.1]}, "joint_box is"),
        ({"joint_box": [0.1, 0.1, -0.1]}, "half-width <= 0"),
        ({"box": [0.1, 0.1, 0.1]}, "takes joint_box and ready"),
        ({"joint_box": [0.1, 0.1, 0.1], "ready": [4.0, 0.0, 0.0]}, "outside the joint ranges"),
    ],
)
def test_a_bad_grasp_section_is_one_line(grasp, message):
    raw = {"name": "elbow", "title": "Elbow", "convention": "standard", "angle_unit": "rad",
           "source": "test", "workspace": {"lower": [0.1, -0.1, 0.1], "upper": [0.3, 0.1, 0.3]},
           "joint": [{"a": 0.2, "d": 0.0, "alpha": 0.0, "lower": -3.0, "upper": 3.0, "home": 0.0,
                      "radius": 0.02}] * 3,
           "grasp": grasp}  # fmt: skip
    with pytest.raises(DHTableError, match=message) as error:
        parse_table(raw, "t.toml")
    assert "\n" not in str(error.value)
