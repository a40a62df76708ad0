"""ReachEnv (RiacsReach-v0, PumaReach-v0): Gymnasium API, determinism, reward and info, control,
bad input, resets, visibility, the documented defaults, the composite frame, vector use, pickling.

Expected values come from the models' own kinematics (robot3df, the PUMA DH product), the scenes'
keyframes, independent norms, and the class docstring parsed here.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import os
import pickle
import re
import signal
import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (chooses the GL back-end, registers the envs)
from envs import reach
from envs.reach import ReachEnv
from envs.robots import grasp_env_ids, reach_env_ids
from models import puma560, riacs
from models.workspace import BoxWorkspace

ROBOTS = ("riacs", "puma560")
ENV_IDS = {"riacs": "RiacsReach-v0", "puma560": "PumaReach-v0"}
SENSING = ("render", "project")
CONTROL = ("servo", "kinematic")
N_DETERMINISM_STEPS = 20
N_COMMANDS = 40  # random commands per control test
SERVO_TOL = 1e-3  # rad
FK_TOL = 1e-9  # m, MuJoCo's site vs the analytic kinematics
KEYFRAME_DIGITS_TOL = 1e-7  # rad: keyframes are written with 7 decimals
GOAL_TOL = 1e-9  # m, compute_reward vs the ground-truth distance with exact projection
FRAME_SHAPE = (reach.IMAGE_HEIGHT, 3 * reach.IMAGE_WIDTH, 3)
CROSSHAIR_RGB = (255, 40, 40)  # composite.CROSSHAIR, written out: the test pins the colour
CROSSHAIR_TOL = 30  # per channel, for anti-aliased pixels (a 1-pixel line is ~10 % dimmer)
#: px checked either side of the centre: the arms run from 6 px (the free centre, where the
#: target shows) to 14 px at a 240-pixel panel height.
CROSSHAIR_GAP, CROSSHAIR_ARM = 7, 13
MIN_FRAME_COLOURS = 50  # a rendered scene has shading; a blank frame has one or two colours
BEHIND_FACTOR = 3.0  # distance behind the cameras, in camera-to-workspace distances
#: s; the vector env script takes ~2 s on an idle machine. Only a hang (the fork-after-render
#: case this guards against) comes near this limit, even on a loaded 2-core machine.
HANG_TIMEOUT = 300.0


def _env(robot: str, **kwargs) -> ReachEnv:
    kwargs.setdefault("sensing", "project")
    kwargs.setdefault("control", "kinematic")
    return ReachEnv(robot=robot, **kwargs)


def _commands(env: ReachEnv, n: int, seed: int) -> np.ndarray:
    """n random in-range joint commands (n, J)."""
    return np.random.default_rng(seed).uniform(env.joint_lower, env.joint_upper, (n, env.joints))


def _reaching_commands(env: ReachEnv, n: int, seed: int) -> np.ndarray:
    """n commands (n, 3) that put the sensed point at random workspace points (in view)."""
    workspace = puma560.WORKSPACE if env.robot == "puma560" else riacs.WORKSPACE
    points = workspace.sample(np.random.default_rng(seed), n)  # (n, 3)
    if env.robot == "riacs":
        return np.stack(riacs.robot3dinv(riacs.LINK1, riacs.LINK2, *points.T), axis=-1)
    theta, reachable = puma560.wrist_ik(points - puma560.BASE_POS, arm=1, elbow=1)
    assert reachable.all()
    return theta


def _sensed_point(robot: str, qpos: np.ndarray) -> np.ndarray:
    """World position of the sensed point from the analytic kinematics (m)."""
    if robot == "riacs":
        return np.array(riacs.robot3df(riacs.LINK1, riacs.LINK2, *qpos[:3]))
    theta = puma560.HOME.copy()
    theta[: len(qpos)] = qpos
    frame = 4 if len(qpos) == 3 else 6  # wrist centre = origin of frame 4, tcp = frame 6
    return puma560.frames(theta)[frame, :3, 3] + puma560.BASE_POS


def _assert_same(a, b, where: str) -> None:
    assert type(a) is type(b), where
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _assert_same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, tuple):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), where
    else:
        assert a == b, where


# -- Gymnasium API ------------------------------------------------------------------------------


# Bounded spaces: Gymnasium warns only that the action is in radians (see ``normalize``).
@pytest.mark.filterwarnings("ignore:.*symmetric and normalized")
@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("control", CONTROL)
@pytest.mark.parametrize("sensing", SENSING)
@pytest.mark.parametrize("robot", ROBOTS)
def test_check_env(robot, sensing, control):
    env = gym.make(ENV_IDS[robot], sensing=sensing, control=control)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("robot", ROBOTS)
def test_check_env_normalized_has_no_warning(robot):
    env = gym.make(ENV_IDS[robot], sensing="project", control="kinematic", normalize=True)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("robot", ROBOTS)
def test_registration(robot):
    spec = gym.spec(ENV_IDS[robot])
    assert spec.kwargs["robot"] == robot
    env = gym.make(ENV_IDS[robot])
    assert env.unwrapped.robot == robot
    env.close()


# -- determinism --------------------------------------------------------------------------------


@pytest.mark.parametrize("robot", ROBOTS)
def test_same_seed_same_episode(robot):
    """Default sensing and control (render, servo): every observation and info key identical."""
    a, b = ReachEnv(robot=robot), ReachEnv(robot=robot)
    _assert_same(a.reset(seed=7), b.reset(seed=7), "reset")
    for i, command in enumerate(_commands(a, N_DETERMINISM_STEPS, seed=8)):
        _assert_same(a.step(command), b.step(command.copy()), f"step {i}")
    a.close()
    b.close()


@pytest.mark.parametrize("robot", ROBOTS)
def test_different_seeds_different_targets(robot):
    env = _env(robot)
    targets = [env.reset(seed=s)[1]["target_pos"] for s in (0, 1, 2)]
    assert not np.allclose(targets[0], targets[1])
    assert not np.allclose(targets[1], targets[2])
    np.testing.assert_array_equal(env.reset(seed=0)[1]["target_pos"], targets[0])  # repeatable


@pytest.mark.parametrize("robot", ROBOTS)
def test_targets_are_drawn_from_the_workspace(robot):
    env = _env(robot)
    env.reset(seed=3)
    targets = np.array([env.reset()[1]["target_pos"] for _ in range(50)])  # (50, 3)
    workspace = puma560.WORKSPACE if robot == "puma560" else riacs.WORKSPACE
    assert workspace.contains(targets).all()
    assert np.unique(targets, axis=0).shape[0] == len(targets)


# -- reward and info ----------------------------------------------------------------------------


@pytest.mark.parametrize(("robot", "joints"), [("riacs", 3), ("puma560", 3), ("puma560", 6)])
def test_reward_terms_and_ground_truth_distance(robot, joints):
    env = _env(robot, joints=joints)
    _, info = env.reset(seed=4)
    np.testing.assert_array_equal(info["target_pos"], env.data.mocap_pos[0])
    for command in _commands(env, N_COMMANDS, seed=5):
        _, reward, terminated, truncated, info = env.step(command)
        expected = _sensed_point(robot, command)
        np.testing.assert_allclose(info["effector_pos"], expected, rtol=0, atol=FK_TOL)
        distance = np.sqrt(np.sum((info["target_pos"] - info["effector_pos"]) ** 2))
        assert info["distance"] == pytest.approx(distance, abs=1e-15)
        if info["visible"]:  # exact projection: the goals triangulate to the true points
            assert info["reward_distance"] == pytest.approx(-info["distance"], abs=GOAL_TOL)
        assert reward == info["reward_distance"] + info["reward_unseen"]
        assert info["reward_unseen"] == (0.0 if info["visible_effector"].all() else -env.reach)
        assert info["is_success"] == (info["distance"] < env.success_threshold)
        assert not terminated and not truncated


@pytest.mark.parametrize("robot", ROBOTS)
def test_success_when_the_arm_reaches_the_target(robot):
    """Kinematic move onto the target by analytic IK: distance 0, success, no pixel error."""
    env = _env(robot, success_threshold=0.001)
    for seed in range(5):
        _, info = env.reset(seed=seed)
        target = info["target_pos"]
        if robot == "riacs":
            command = np.array(riacs.robot3dinv(riacs.LINK1, riacs.LINK2, *target))
        else:
            command, _ = puma560.wrist_ik(target - puma560.BASE_POS, arm=1, elbow=1)
        obs, _, _, _, info = env.step(command)
        assert info["distance"] < 1e-9 and info["is_success"] and info["visible"]
        assert info["pixel_error"] < 1e-6
        np.testing.assert_allclose(obs["achieved_goal"], obs["desired_goal"], atol=1e-6)
        miss = command + 0.01  # rad: a few mm off, more than 1 mm
        _, _, _, _, info = env.step(np.clip(miss, env.joint_lower, env.joint_upper))
        assert info["distance"] > 0.001 and not info["is_success"]


@pytest.mark.parametrize("robot", ROBOTS)
def test_pixel_error_is_the_mean_image_distance(robot):
    env = _env(robot)
    env.reset(seed=6)
    for command in _reaching_commands(env, 10, seed=7):
        obs, _, _, _, info = env.step(command)
        assert info["visible"]
        gap = obs["achieved_goal"] - obs["desired_goal"]
        left, right = np.hypot(gap[0], gap[1]), np.hypot(gap[2], gap[3])
        assert info["pixel_error"] == pytest.approx((left + right) / 2, rel=1e-12)


@pytest.mark.parametrize("robot", ROBOTS)
def test_compute_reward_equals_step_reward_with_project_sensing(robot):
    env = _env(robot)
    env.reset(seed=8)
    achieved, desired, rewards = [], [], []
    for command in _reaching_commands(env, 20, seed=9):
        obs, reward, _, _, info = env.step(command)
        assert info["visible"]
        got = env.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
        assert float(got) == pytest.approx(reward, abs=GOAL_TOL)
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        rewards.append(reward)
    batch = env.compute_reward(np.array(achieved), np.array(desired), None)  # HER: (N, 4) goals
    assert batch.shape == (len(rewards),)
    np.testing.assert_allclose(batch, rewards, rtol=0, atol=GOAL_TOL)


# -- control ------------------------------------------------------------------------------------


@pytest.mark.parametrize(("robot", "joints"), [("riacs", 3), ("puma560", 3), ("puma560", 6)])
def test_kinematic_control_lands_exactly_on_the_command(robot, joints):
    env = _env(robot, joints=joints)
    env.reset(seed=10)
    home = env.model.key("home").qpos
    for command in _commands(env, N_COMMANDS, seed=11):
        obs, _, _, _, info = env.step(command)
        np.testing.assert_array_equal(obs["observation"], command)
        np.testing.assert_array_equal(env.data.qpos[:joints], command)
        np.testing.assert_array_equal(env.data.qpos[joints:], home[joints:])  # others held
        assert info["settle_time"] == 0.0 and not info["clipped"]


@pytest.mark.parametrize("robot", ["riacs", "puma560"])
def test_servo_control_reaches_the_command(robot):
    env = _env(robot, control="servo")
    env.reset(seed=12)
    errors = []
    for command in _commands(env, 100, seed=2):
        obs, *_ = env.step(command)
        errors.append(np.abs(obs["observation"] - command).max())
    assert max(errors) < SERVO_TOL, f"worst joint error {max(errors) * 1e3:.2f} mrad"


@pytest.mark.parametrize("robot", ROBOTS)
def test_servo_move_follows_the_documented_settle_rule(robot):
    """Each move ends with every joint slower than SETTLE_SPEED, between the time limits."""
    env = _env(robot, control="servo")
    env.reset(seed=13)
    for command in _commands(env, 10, seed=14):
        _, _, _, _, info = env.step(command)
        assert reach.MIN_SETTLE_TIME <= info["settle_time"] <= reach.MAX_SETTLE_TIME + 1e-9
        if info["settle_time"] < reach.MAX_SETTLE_TIME:
            assert np.abs(env.data.qvel).max() < reach.SETTLE_SPEED
        np.testing.assert_array_equal(env.data.ctrl[: env.joints], command)


@pytest.mark.parametrize("control", CONTROL)
@pytest.mark.parametrize("robot", ROBOTS)
def test_out_of_range_command_is_clipped(robot, control):
    env = _env(robot, control=control)
    env.reset(seed=15)
    command = env.joint_lower - 0.5  # rad below every lower limit ...
    command[-1] = env.joint_upper[-1] + 0.5  # ... and above the last upper one
    clipped = np.clip(command, env.joint_lower, env.joint_upper)
    _, _, _, _, info = env.step(command)
    assert info["clipped"] is True
    applied = env.data.ctrl if control == "servo" else env.data.qpos
    np.testing.assert_array_equal(applied[: env.joints], clipped)
    _, _, _, _, info = env.step((env.joint_lower + env.joint_upper) / 2)
    assert info["clipped"] is False


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("robot", ROBOTS)
def test_non_finite_action_names_the_joint(robot, bad):
    env = _env(robot)
    env.reset(seed=16)
    action = (env.joint_lower + env.joint_upper) / 2
    action[1] = bad
    with pytest.raises(ValueError, match=r"joint2\b"):
        env.step(action)


@pytest.mark.parametrize("shape", [(2,), (4,), (1, 3), ()])
def test_wrong_action_shape_states_the_expected_shape(shape):
    env = _env("riacs")
    env.reset(seed=17)
    with pytest.raises(ValueError, match=re.escape("(3,)")):
        env.step(np.zeros(shape))


def test_wrong_action_shape_for_six_joints():
    env = _env("puma560", joints=6)
    env.reset(seed=17)
    with pytest.raises(ValueError, match=re.escape("(6,)")):
        env.step(np.zeros(3))


@pytest.mark.parametrize(
    ("option", "value", "valid"),
    [
        ("sensing", "camera", ("render", "project")),
        ("control", "torque", ("servo", "kinematic")),
        ("robot", "ur5", ("riacs", "puma560")),
    ],
)
def test_unknown_option_lists_the_valid_ones(option, value, valid):
    kwargs = {"robot": "riacs", option: value}
    with pytest.raises(ValueError) as excinfo:
        ReachEnv(**kwargs)
    message = str(excinfo.value)
    assert repr(value) in message
    for name in valid:
        assert name in message


@pytest.mark.parametrize(("robot", "joints"), [("riacs", 6), ("puma560", 4)])
def test_unsupported_joint_count_is_refused(robot, joints):
    with pytest.raises(ValueError, match=str(joints)):
        ReachEnv(robot=robot, joints=joints)


# -- resets and episode end ---------------------------------------------------------------------


@pytest.mark.parametrize("control", CONTROL)
@pytest.mark.parametrize("robot", ROBOTS)
def test_reset_keep_arm_and_home(robot, control):
    env = _env(robot, control=control)
    home = env.model.key("home").qpos[: env.joints].copy()
    analytic_home = riacs.HOME if robot == "riacs" else puma560.HOME[:3]
    np.testing.assert_allclose(home, analytic_home, atol=KEYFRAME_DIGITS_TOL)
    obs, info0 = env.reset(seed=18)
    np.testing.assert_array_equal(obs["observation"], home)
    for command in _commands(env, 3, seed=19):
        obs, *_ = env.step(command)
    moved = obs["observation"].copy()
    assert not np.allclose(moved, home)
    kept, info1 = env.reset(options={"keep_arm": True})
    np.testing.assert_array_equal(kept["observation"], moved)
    np.testing.assert_array_equal(env.data.qvel, 0.0)
    assert not np.allclose(info1["target_pos"], info0["target_pos"])  # a new target
    fresh, _ = env.reset()
    np.testing.assert_array_equal(fresh["observation"], home)
    np.testing.assert_array_equal(env.data.qpos, env.model.key("home").qpos)


@pytest.mark.parametrize("robot", ROBOTS)
def test_truncated_after_four_moves_never_terminated(robot):
    env = gym.make(ENV_IDS[robot], sensing="project", control="kinematic")
    env.reset(seed=20)
    for episode in range(2):
        flags = []
        for command in _commands(env.unwrapped, 4, seed=21 + episode):
            _, _, terminated, truncated, _ = env.step(command)
            flags.append((terminated, truncated))
        assert flags == [(False, False)] * 3 + [(False, True)]
        env.reset()
    env.close()


# -- visibility ---------------------------------------------------------------------------------


def _move_targets_to(env: ReachEnv, point: np.ndarray) -> None:
    """Make every following reset put the target at ``point``."""
    p = np.asarray(point, dtype=float)
    env.robot_spec = dataclasses.replace(env.robot_spec, workspace=BoxWorkspace(p, p))


def _far_off_image(env: ReachEnv) -> np.ndarray:
    """A point 1 m in front of the left camera and 30 focal lengths to its right."""
    cam = env.stereo.cameras[0]
    return cam.position + 30.0 * cam.rotation[:, 0] - cam.rotation[:, 2]


@pytest.mark.parametrize("sensing", SENSING)
@pytest.mark.parametrize("robot", ROBOTS)
def test_target_out_of_view_keeps_the_last_sensing(robot, sensing):
    env = _env(robot, sensing=sensing)
    centre = np.tile([(reach.IMAGE_WIDTH - 1) / 2, (reach.IMAGE_HEIGHT - 1) / 2], 2)
    seen, info = env.reset(seed=22)
    assert info["visible"]
    _move_targets_to(env, _far_off_image(env))
    obs, info = env.reset()
    assert not info["visible"] and not info["visible_target"].any()
    np.testing.assert_array_equal(obs["desired_goal"], seen["desired_goal"])
    # Before any valid sighting the documented placeholder is the image centre.
    fresh = _env(robot, sensing=sensing)
    _move_targets_to(fresh, _far_off_image(fresh))
    obs, info = fresh.reset(seed=22)
    assert not info["visible"]
    np.testing.assert_array_equal(obs["desired_goal"], centre)


@pytest.mark.parametrize("sensing", ["render", "project"])
@pytest.mark.parametrize("robot", ROBOTS)
def test_target_behind_the_cameras_is_not_visible(robot, sensing):
    env = _env(robot, sensing=sensing)
    env.reset(seed=23)
    # The workspace centre mirrored through the midpoint of the camera centres and pushed back:
    # behind both cameras, close to the reversed optical axes (the pinhole maps it into view).
    workspace = puma560.WORKSPACE if robot == "puma560" else riacs.WORKSPACE
    middle = (env.stereo.cameras[0].position + env.stereo.cameras[1].position) / 2
    behind = middle + BEHIND_FACTOR * (middle - (workspace.lower + workspace.upper) / 2)
    for k in range(2):  # precondition, from MuJoCo's camera frames: behind, yet "in" the image
        cid = env.model.camera(("cam_left", "cam_right")[k]).id
        backwards = env.data.cam_xmat[cid].reshape(3, 3)[:, 2]
        assert (behind - env.data.cam_xpos[cid]) @ backwards > 0
    pixels = env.stereo.project(behind)[0]
    assert np.all((pixels >= 0) & (pixels < np.tile([reach.IMAGE_WIDTH, reach.IMAGE_HEIGHT], 2)))
    _move_targets_to(env, behind)
    _, info = env.reset()
    assert not info["visible_target"].any()


@pytest.mark.parametrize("sensing", SENSING)
def test_effector_out_of_view_keeps_the_last_sensing(sensing):
    """PUMA with the upper arm raised vertically and the forearm horizontal: wrist above images."""
    env = _env("puma560", sensing=sensing)
    env.reset(seed=24)
    seen, *_ = env.step(np.array([np.pi / 2, -np.pi / 2, 0.0]))  # arm reaching forward
    obs, _, _, _, info = env.step(np.array([np.pi / 2, -np.pi / 2, np.pi / 2]))
    pixels = env.stereo.project(info["effector_pos"])[0]
    assert pixels[1] < 0 and pixels[3] < 0  # precondition: above both images
    assert not info["visible"] and not info["visible_effector"].any()
    np.testing.assert_array_equal(obs["achieved_goal"], seen["achieved_goal"])
    assert info["distance"] > 0  # ground truth still reported


def test_hidden_effector_marker_is_not_visible_with_render_sensing():
    """RIACS marker removed from every drawn geom group: nothing green to find."""
    env = _env("riacs", sensing="render")
    seen, _ = env.reset(seed=25)
    env.model.geom_group[env.model.geom("marker_tcp").id] = 5  # a group the cameras never draw
    obs, _, _, _, info = env.step((env.joint_lower + env.joint_upper) / 3)
    assert not info["visible"] and not info["visible_effector"].any()
    assert info["visible_target"].all()
    np.testing.assert_array_equal(obs["achieved_goal"], seen["achieved_goal"])


# -- documented defaults ------------------------------------------------------------------------


def _doc() -> str:
    return " ".join(inspect.getdoc(ReachEnv).split())  # whitespace collapsed


def test_docstring_pins_every_argument_default():
    doc = inspect.getdoc(ReachEnv)
    arguments = doc.split("## Arguments", 1)[1]
    documented = {
        name: ast.literal_eval(default.replace("``", ""))
        for name, default in re.findall(r"^- ``(\w+)`` \((.+?)\):", arguments, flags=re.M)
    }
    signature = inspect.signature(ReachEnv.__init__).parameters
    defaults = {n: p.default for n, p in signature.items() if n != "self"}
    assert documented == defaults
    assert documented["success_threshold"] == reach.SUCCESS_THRESHOLD == 0.005  # 5 mm


def test_docstring_pins_the_settle_rule_and_image_size():
    doc = _doc()
    speed, t_min, t_max = re.search(
        r"slower than ([\d.e+-]+) rad/s.*?\(at least ([\d.]+) s, at most ([\d.]+) s", doc
    ).groups()
    assert float(speed) == reach.SETTLE_SPEED
    assert float(t_min) == reach.MIN_SETTLE_TIME
    assert float(t_max) == reach.MAX_SETTLE_TIME
    width, height = map(int, re.search(r"(\d+)×(\d+) images", doc).groups())
    assert (width, height) == (reach.IMAGE_WIDTH, reach.IMAGE_HEIGHT)
    env = _env("riacs", sensing="render")
    assert (env.stereo.width, env.stereo.height) == (width, height)
    env.reset(seed=26)
    (image, depth), _ = env.stereo.render_views(env.data, (0, 2))
    assert image.shape == (height, width, 3) and depth.shape == (height, width)


def test_docstring_pins_the_episode_length_and_registrations():
    doc = _doc()
    steps = int(re.search(r"registered default (\d+)", doc).group(1))
    assert steps == reach.MAX_EPISODE_STEPS
    for robot, env_id in ENV_IDS.items():
        assert gym.spec(env_id).max_episode_steps == steps
        assert gym.spec(env_id).kwargs["robot"] == robot
    assert "PUMA 560 (``PumaReach-v0``)" in doc and "RIACS 3-DOF arm (``RiacsReach-v0``)" in doc


def test_docstring_pins_spaces_and_info_keys():
    doc = inspect.getdoc(ReachEnv)
    rows = re.findall(r"^\| ``(\w+)`` \| \((\w+),\) \| (\w+) \|", doc, flags=re.M)
    sizes = {"J": 3, "4": 4}
    for joints in (3, 6):
        env = _env("puma560", joints=joints)
        sizes["J"] = joints
        assert env.observation_space.keys() == {name for name, _, _ in rows}
        for name, size, _ in rows:
            assert env.observation_space[name].shape == (sizes[size],)
        assert env.action_space.shape == (joints,) and env.action_space.dtype == np.float64
        np.testing.assert_allclose(env.action_space.low, puma560.DH.lower[:joints], atol=1e-6)
        np.testing.assert_allclose(env.action_space.high, puma560.DH.upper[:joints], atol=1e-6)
    info_section = doc.split("## Info", 1)[1].split("##", 1)[0]
    documented = set(re.findall(r"``(\w+)``", info_section)) - {"success_threshold"}
    env = _env("riacs")
    _, info = env.reset(seed=27)
    assert set(info) == documented
    _, _, _, _, info = env.step(env.action_space.sample())
    assert set(info) == documented


# -- rendering ----------------------------------------------------------------------------------


@pytest.mark.parametrize("robot", ROBOTS)
def test_rgb_array_frame(robot):
    env = _env(robot, sensing="render", render_mode="rgb_array")
    obs, _ = env.reset(seed=28)
    obs, *_ = env.step((env.joint_lower + env.joint_upper) / 2)
    frame = env.render()
    assert frame.shape == FRAME_SHAPE and frame.dtype == np.uint8
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) >= MIN_FRAME_COLOURS
    # The crosshair is drawn anti-aliased: its pixels are within CROSSHAIR_TOL of the colour.
    near = np.all(np.abs(frame.astype(int) - CROSSHAIR_RGB) <= CROSSHAIR_TOL, axis=-1)  # (H, 3W)
    side = np.arange(CROSSHAIR_GAP, CROSSHAIR_ARM + 1)
    arm = np.concatenate([-side[::-1], side])  # px along each line, outside the free centre
    for k in range(2):  # on each camera view, centred on the sensed target
        u, v = np.round(obs["desired_goal"][2 * k : 2 * k + 2]).astype(int)
        u += k * reach.IMAGE_WIDTH
        assert near[v, u + arm].mean() > 0.8, f"camera {k}: no horizontal crosshair line"
        assert near[v + arm, u].mean() > 0.8, f"camera {k}: no vertical crosshair line"
        far = (
            v + 2 * CROSSHAIR_ARM
            if v + 2 * CROSSHAIR_ARM < FRAME_SHAPE[0]
            else v - 2 * CROSSHAIR_ARM
        )
        assert not near[far, u + arm].any(), f"camera {k}: not a crosshair"
    env.close()


def test_no_render_mode_renders_nothing():
    env = _env("riacs")
    env.reset(seed=29)
    assert env.render() is None


# -- vector envs and pickling -------------------------------------------------------------------


def _make_render_env():
    return gym.make("RiacsReach-v0", sensing="render", control="kinematic")


def _run_vector(vector_env) -> list:
    out = [vector_env.reset(seed=[30, 31])]
    rng = np.random.default_rng(32)
    space = vector_env.single_action_space
    for _ in range(5):
        out.append(vector_env.step(rng.uniform(space.low, space.high, (2, 3))))
    vector_env.close()
    return out


def test_async_and_sync_vector_envs_agree():
    """Forkserver workers (the parent here has rendered already, see the fork test)."""
    sync = _run_vector(gym.vector.SyncVectorEnv([_make_render_env] * 2))
    asynchronous = _run_vector(
        gym.vector.AsyncVectorEnv([_make_render_env] * 2, context="forkserver")
    )
    assert len(sync) == len(asynchronous)
    for i, (a, b) in enumerate(zip(sync, asynchronous, strict=True)):
        observations = (a[0], b[0])
        for key in observations[0]:
            np.testing.assert_array_equal(observations[0][key], observations[1][key], f"{i}")
        if i:
            np.testing.assert_array_equal(a[1], b[1])  # rewards
            np.testing.assert_array_equal(a[3], b[3])  # truncated
    assert not np.array_equal(sync[0][0]["desired_goal"][0], sync[0][0]["desired_goal"][1])


_FORK_SCRIPT = textwrap.dedent(
    """
    import sys
    import gymnasium as gym
    import envs
    from envs.reach import ReachEnv

    def make():
        return gym.make("RiacsReach-v0", sensing="render", control="kinematic")

    if sys.argv[1] == "render-first":  # e.g. a script that rendered a video, then trains
        parent = ReachEnv()
        parent.reset(seed=0)
        parent.close()
    vec = gym.vector.AsyncVectorEnv([make, make])  # default context: fork on Linux
    try:
        vec.reset(seed=[0, 1])
        vec.step(vec.action_space.sample())
    except Exception as exc:
        print("ERROR", exc)
        sys.exit(3)
    finally:
        vec.close()
    print("OK")
    """
)


def _run_fork_script(tmp_path, mode: str) -> tuple[int, str]:
    """Run the script in its own process group; on a timeout, end the group (its workers too)."""
    script = tmp_path / "vector_fork.py"
    script.write_text(_FORK_SCRIPT)
    process = subprocess.Popen(
        [sys.executable, str(script), mode],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        cwd=tmp_path,
        start_new_session=True,
    )
    try:
        output, _ = process.communicate(timeout=HANG_TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        output, _ = process.communicate()
        pytest.fail(
            f"AsyncVectorEnv ({mode}) hung: no result after {HANG_TIMEOUT:.0f} s (about 2 s when "
            f"it works); its output:\n{output[-2000:]}"
        )
    return process.returncode, output


def test_async_vector_env_with_the_default_context(tmp_path):
    returncode, output = _run_fork_script(tmp_path, "fresh")
    assert returncode == 0 and "OK" in output, output[-2000:]


def test_fork_after_rendering_fails_fast_or_works(tmp_path):
    """Never a hang: either it works, or the worker says which start method to use."""
    returncode, output = _run_fork_script(tmp_path, "render-first")
    assert returncode == 0 or "forkserver" in output, output[-2000:]


@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaReach-v0", "PumaGrasp-v0"])
def test_skipping_targets_leaves_the_generator_where_resets_leave_it(env_id):
    """skip_targets(k) then a reset draws the target (and object pose) of the (k+1)-th reset,
    and the arm stays where it was."""
    walked = gym.make(env_id, sensing="project", control="kinematic")
    skipped = gym.make(env_id, sensing="project", control="kinematic")
    walked.reset(seed=4)
    skipped.reset(seed=4)
    for k in (0, 1, 5):
        for _ in range(k):
            walked.reset()
        qpos = skipped.unwrapped.data.qpos.copy()
        skipped.unwrapped.skip_targets(k)
        np.testing.assert_array_equal(skipped.unwrapped.data.qpos, qpos)
        a, b = walked.reset()[1], skipped.reset()[1]
        np.testing.assert_array_equal(a["target_pos"], b["target_pos"])
        if "target_pose" in a:
            np.testing.assert_array_equal(a["target_pose"], b["target_pose"])
    walked.close()
    skipped.close()


@pytest.mark.parametrize("env_id", [*reach_env_ids(), *grasp_env_ids()])
def test_every_registered_env_pickles_with_its_robot_model(env_id):
    """What ``AsyncVectorEnv`` does to an env made by ``gym.make``: the copy, robot model and
    pose task included (no lambdas in them), steps as the original does."""
    env = gym.make(env_id, sensing="project", control="kinematic")
    env.reset(seed=5)
    copy = pickle.loads(pickle.dumps(env))
    command = env.action_space.sample()
    _assert_same(env.step(command), copy.step(command), "step")
    env.close()
    copy.close()


@pytest.mark.parametrize("robot", ROBOTS)
def test_env_pickles_and_the_copy_behaves_the_same(robot):
    env = ReachEnv(robot=robot, sensing="render", control="servo", render_mode="rgb_array")
    copy = pickle.loads(pickle.dumps(env))  # before any rendering
    _assert_same(env.reset(seed=33), copy.reset(seed=33), "reset")
    command = (env.joint_lower + 2 * env.joint_upper) / 3
    _assert_same(env.step(command), copy.step(command), "step")
    assert env.render().shape == FRAME_SHAPE
    again = pickle.loads(pickle.dumps(env))  # after rendering: renderers are left behind
    _assert_same(again.step(command), env.step(command), "step after unpickling")
    for e in (env, copy, again):
        e.close()
