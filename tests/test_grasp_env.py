"""PumaGrasp-v0: the goal-env contract, spaces, reward against the ground truth, the exact-IK
move, determinism, normalisation, perturbation, the documented defaults, and PumaReach-v0
unchanged by the shared machinery."""

from __future__ import annotations

import ast
import inspect
import json
import os
import re
import subprocess
import sys
import textwrap
from importlib.util import find_spec

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (chooses the GL back-end, registers the envs)
from envs import grasp
from envs.goal_env import GoalEnvWrapper
from envs.grasp import GRASP_ENV_IDS, ORIENTATION_WEIGHT, GraspEnv
from models.puma560 import ARM_REACH, WORKSPACE
from models.puma560.grasp import (
    MAX_TILT,
    NOMINAL_ORIENTATION,
    UPRIGHT_ORIENTATION,
    WIDE,
    marker_points,
    orientation_angle,
)
from models.puma560.inverse import D6
from models.puma560.kinematics import frames
from models.rotations import rotvec_to_matrix


def _transitions(env: GraspEnv, episodes: int, seed: int) -> list[tuple]:
    """(achieved, desired, info, reward) of every reset-free step: coarse moves near the
    target's joints, and one far off (the hand out of view: unseen)."""
    rng = np.random.default_rng(seed)
    out = []
    for episode in range(episodes):
        env.reset(seed=seed + episode)
        for move in range(3):
            command = env.target_joints + rng.normal(0.0, 0.15, 6)
            if move == 2 and episode % 2:  # the arm stretched up: the hand above the images
                command = np.array([0.0, -np.pi / 2, np.pi / 2, 0.0, 0.0, 0.0])
            command = np.clip(command, env.joint_lower, env.joint_upper)
            if env.normalize:
                command = (command - env._joint_mid) / env._joint_half
            obs, reward, _, _, info = env.step(command)
            out.append((obs["achieved_goal"], obs["desired_goal"], info, reward))
    return out


# -- Gymnasium API --------------------------------------------------------------------------------


@pytest.mark.filterwarnings("ignore:.*symmetric and normalized")
@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize(
    ("sensing", "control"),
    [("project", "kinematic"), ("render", "servo"), ("foveated", "kinematic")],
)
def test_check_env(sensing, control):
    env = gym.make("PumaGrasp-v0", sensing=sensing, control=control)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize(
    "options",
    [
        {},
        {"orientations": "ball:30", "action_range": "joints"},
        {"orientations": "yaw:180,tilt:60"},
    ],
)
def test_check_env_normalized_has_no_warning(options):
    env = gym.make(
        "PumaGrasp-v0", sensing="project", control="kinematic", normalize=True, **options
    )
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_the_task_box_holds_every_grasp_and_random_actions_in_it_see_the_hand():
    """The default action space is the task's joint box: inside the joint ranges, holding the
    exact grasp of every object, its bounds what normalised actions ±1 command; a uniformly
    random action there leaves the hand in both cameras' (projected) views far more often than
    one over the whole joint ranges (measured 85 % against 50 %)."""
    seen = {}
    for action_range in ("task", "joints"):
        env = gym.make("PumaGrasp-v0", sensing="project", control="kinematic",
                       action_range=action_range)  # fmt: skip
        base = env.unwrapped
        space = env.action_space
        assert np.all(space.low >= base.joint_lower) and np.all(space.high <= base.joint_upper)
        env.reset(seed=11)
        space.seed(11)
        visible = []
        for _ in range(100):
            env.reset()
            assert np.all(space.low <= base.target_joints)
            assert np.all(base.target_joints <= space.high)
            for _ in range(4):
                _, _, _, _, info = env.step(space.sample())
                visible.append(info["visible_effector"].all())
        seen[action_range] = np.mean(visible)
        env.close()
    assert seen["task"] >= 0.7 and seen["joints"] <= 0.6, seen
    env = gym.make("PumaGrasp-v0", sensing="project", control="kinematic", normalize=True)
    env.reset(seed=0)
    box = env.unwrapped
    for sign, bound in ((-1.0, box.action_lower), (1.0, box.action_upper)):
        obs, *_ = env.step(np.full(6, sign, dtype=np.float32))
        joints = (
            box.joint_lower + (obs["observation"] + 1.0) * (box.joint_upper - box.joint_lower) / 2
        )
        np.testing.assert_allclose(joints, bound, atol=1e-9)
    env.close()


def test_registration_wraps_the_goal_env():
    assert GRASP_ENV_IDS == ("PumaGrasp-v0", "Ur5eGrasp-v0", "PandaGrasp-v0")  # the registry's
    env = gym.make("PumaGrasp-v0", sensing="project", control="kinematic")
    assert isinstance(env, GoalEnvWrapper) and env.spec.max_episode_steps == 4
    obs, info = env.reset(seed=1)
    assert env.compute_reward(obs["achieved_goal"], obs["desired_goal"], info) == (
        env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
    )
    env.close()


def test_spaces_are_bounded_and_hold_every_observation():
    env = GraspEnv(sensing="render", control="servo")
    assert env.action_space.shape == (6,) and env.observation_space["observation"].shape == (6,)
    for key in ("achieved_goal", "desired_goal"):
        space = env.observation_space[key]
        assert space.shape == (12,) and space.is_bounded()
        np.testing.assert_array_equal(space.high, np.tile([319.0, 239.0], 6))
    assert env.observation_space["observation"].is_bounded()
    for achieved, desired, _, _ in _transitions(env, 2, seed=3):
        assert env.observation_space["achieved_goal"].contains(achieved)
        assert env.observation_space["desired_goal"].contains(desired)
    env.close()


# -- reward -------------------------------------------------------------------------------------


@pytest.mark.parametrize(("sensing", "normalize"), [("render", False), ("project", True)])
def test_reward_equals_compute_reward_bit_for_bit_single_and_batched(sensing, normalize):
    # Over the whole joint ranges random actions lose the hand often: unseen steps included.
    env = GraspEnv(sensing=sensing, control="kinematic", normalize=normalize, action_range="joints")
    rows = _transitions(env, 4, seed=11)
    assert any(not info["visible_effector"].all() for _, _, info, _ in rows)  # unseen included
    for achieved, desired, info, reward in rows:
        terms = [info[k] for k in GraspEnv.REWARD_TERMS]
        assert reward == (terms[0] + terms[1]) + terms[2]
        assert env.compute_reward(achieved, desired, info) == reward
    achieved = np.stack([r[0] for r in rows])  # (N, 12)
    desired = np.stack([r[1] for r in rows])
    infos = [r[2] for r in rows]
    rewards = np.array([r[3] for r in rows])
    np.testing.assert_array_equal(env.compute_reward(achieved, desired, infos), rewards)
    odd = slice(None, None, 2)  # a strided batch, and a 2-D one, as replay buffers pass them
    np.testing.assert_array_equal(
        env.compute_reward(achieved[odd], desired[odd], infos[odd]), rewards[odd]
    )
    n = 2 * (len(rows) // 2)
    shaped = env.compute_reward(
        achieved[:n].reshape(2, -1, 12),
        desired[:n].reshape(2, -1, 12),
        np.array(infos[:n], dtype=object).reshape(2, -1),
    )
    np.testing.assert_array_equal(shaped, rewards[:n].reshape(2, -1))
    env.close()


def test_reward_terms_are_the_ground_truth_in_project_mode():
    """With exact projection the triangulated fit is exact: the terms are minus the ground-truth
    distance, minus ORIENTATION_WEIGHT times the ground-truth angle, and the unseen penalty."""
    env = GraspEnv(sensing="project", control="kinematic")
    for _, _, info, _ in _transitions(env, 4, seed=21):
        seen = info["visible_effector"].all()
        assert info["reward_unseen"] == (0.0 if seen else -ARM_REACH)
        if seen:
            assert info["reward_distance"] == pytest.approx(-info["distance"], abs=1e-9)
            want = -ORIENTATION_WEIGHT * info["orientation_error"]
            assert info["reward_orientation"] == pytest.approx(want, abs=1e-9)
        angle = orientation_angle(info["effector_pose"][:3, :3], info["target_pose"][:3, :3])
        assert info["orientation_error"] == pytest.approx(float(angle), abs=1e-12)
        tcp_to_object = np.linalg.norm(info["effector_pose"][:3, 3] - info["target_pose"][:3, 3])
        assert info["distance"] == pytest.approx(tcp_to_object, abs=1e-12)
    env.close()


def test_wrong_goal_shape_is_one_clear_error():
    env = GraspEnv(sensing="project", control="kinematic")
    with pytest.raises(ValueError, match=r"goals are \(\.\.\., 12\) pixel vectors"):
        env.compute_reward(np.zeros(4), np.zeros(4), None)
    env.close()


# -- the task -----------------------------------------------------------------------------------


@pytest.mark.parametrize("control", ["kinematic", "servo"])
def test_move_to_the_exact_ik_joints_grasps_the_object(control):
    """The joints sample_grasp_pose returns put the tool frame on the object's frame: distance
    and orientation error ≈ 0 (servo: settled within its tolerance), success, reward ≈ 0."""
    env = GraspEnv(sensing="project", control=control)
    tolerance = (1e-9, 1e-9) if control == "kinematic" else (5e-4, 5e-3)  # m, rad
    for seed in range(6):
        env.reset(seed=seed)
        _, reward, _, _, info = env.step(env.target_joints)
        assert info["distance"] < tolerance[0] and info["orientation_error"] < tolerance[1]
        assert info["is_success"] and info["visible"]
        assert -reward < tolerance[0] + ORIENTATION_WEIGHT * tolerance[1] + 1e-9
    env.close()


@pytest.mark.parametrize("orientations", ["yaw:90,tilt:45", "ball:30"])
def test_objects_are_reachable_poses_within_the_range(orientations):
    """The object's pose: its wrist point (D6 back along its z axis) inside the workspace box,
    its orientation in the range (the wide one: the approach's angle from the vertical and the
    turn about it, measured here by hand); the target joints reach it (DH product)."""
    env = GraspEnv(sensing="project", control="kinematic", orientations=orientations)
    for seed in range(20):
        _, info = env.reset(seed=seed)
        pose = info["target_pose"]
        wrist = pose[:3, 3] - D6 * pose[:3, 2]
        assert WORKSPACE.contains(wrist[None])[0]
        R = pose[:3, :3]
        if orientations == "ball:30":
            assert orientation_angle(R, NOMINAL_ORIENTATION) <= MAX_TILT + 1e-12
        else:
            tilt = np.arccos(-R[2, 2])  # the approach (tool z) from straight down
            assert tilt <= np.radians(45) + 1e-12
            # The crossbar (tool y) turned about the vertical from its upright direction.
            upright_y = UPRIGHT_ORIENTATION[:, 1]
            lean_axis = np.cross(R[:, 2], [0.0, 0.0, -1.0])
            y_upright = (
                rotvec_to_matrix(lean_axis / max(np.linalg.norm(lean_axis), 1e-300) * tilt)
                @ R[:, 1]
            )
            yaw = np.arctan2(np.cross(upright_y, y_upright)[2], upright_y @ y_upright)
            assert abs(yaw) <= np.radians(90) + 1e-9
        tool = frames(env.target_joints)[6]  # frame 0 coordinates
        np.testing.assert_allclose(tool[:3, :3], pose[:3, :3], atol=1e-9)
        assert np.all(env.target_joints >= env.joint_lower)
        assert np.all(env.target_joints <= env.joint_upper)
    env.close()


def test_the_wide_range_fills_yaw_and_tilt():
    """Drawn orientations cover the wide range: yaw to near ±90°, tilt to near 45° (not a cone
    about the nominal as the ball's)."""
    rng = np.random.default_rng(0)
    draws = np.array([WIDE.sample(rng) for _ in range(3000)])
    tilt = np.degrees(np.arccos(-draws[:, 2, 2]))
    assert tilt.max() > 43 and np.mean(tilt > 30) > 0.3
    crossbar = np.degrees(np.arctan2(draws[:, 1, 1], draws[:, 0, 1]))  # tool y's azimuth
    assert np.ptp(crossbar) > 170  # ±90° of yaw turn the crossbar through 180°


@pytest.mark.parametrize(
    "spelling, message",
    [
        ("yaw:90,tilt:85", "tilt is 85°; it must lie in [0, 80]°"),
        ("yaw:200,tilt:45", "yaw is 200°; it must lie in [0, 180]°"),
        ("ball:30,yaw:2", "names ['ball', 'yaw']"),
        ("tilt=45", "cannot be read"),
    ],
)
def test_an_orientation_range_out_of_reach_is_refused_in_one_line(spelling, message):
    with pytest.raises(ValueError, match=re.escape(message)) as caught:
        GraspEnv(sensing="project", control="kinematic", orientations=spelling)
    assert "\n" not in str(caught.value)


def test_success_needs_position_and_orientation():
    env = GraspEnv(sensing="project", control="kinematic")
    env.reset(seed=4)
    turned = env.target_joints.copy()
    turned[5] += 2 * grasp.ORIENTATION_THRESHOLD  # joint 6 turns the hand about the tool axis
    _, _, _, _, info = env.step(turned)
    assert info["distance"] < 1e-9 and info["orientation_error"] > grasp.ORIENTATION_THRESHOLD
    assert not info["is_success"]
    env.close()


def test_an_unseen_marker_keeps_its_last_sighting_the_others_move_on():
    """The blue hand marker drawn in a group no camera draws: red and green are sensed where
    they are (the exact projection, within render's error), blue keeps its previous goal, and
    the hand counts as unseen."""
    env = GraspEnv(sensing="render", control="kinematic")
    exact = GraspEnv(sensing="project", control="kinematic")
    env.reset(seed=6)
    exact.reset(seed=6)
    first, _, _, _, _ = env.step(env.target_joints)
    env.model.geom_group[env.model.geom("hand_marker_magenta").id] = 5
    command = env.target_joints + 0.05
    obs, reward, _, _, info = env.step(command)
    truth, *_ = exact.step(command)
    assert info["visible_effector"].tolist() == [False, False] and not info["visible"]
    assert info["reward_unseen"] == -env.reach and reward <= -env.reach
    np.testing.assert_array_equal(obs["achieved_goal"][8:], first["achieved_goal"][8:])
    moved = np.abs(obs["achieved_goal"][:8] - first["achieved_goal"][:8]).max()
    assert moved > 5.0  # px: red and green followed the hand
    np.testing.assert_allclose(obs["achieved_goal"][:8], truth["achieved_goal"][:8], atol=1.5)
    assert np.isnan(env.sensed_effector()[8:]).all()
    env.close()
    exact.close()


def test_same_seed_same_episode():
    a, b = (GraspEnv(sensing="foveated", control="servo") for _ in range(2))
    for env in (a, b):
        env.reset(seed=9)
    oa, ob = a.reset(seed=9)[0], b.reset(seed=9)[0]
    for key in oa:
        np.testing.assert_array_equal(oa[key], ob[key])
    command = a.target_joints + 0.05
    ra, rb = a.step(command), b.step(command)
    for key in ra[0]:
        np.testing.assert_array_equal(ra[0][key], rb[0][key])
    assert ra[1] == rb[1] and ra[4]["settle_time"] == rb[4]["settle_time"]
    a.close()
    b.close()


def test_normalized_goals_map_back_onto_the_pixels():
    raw = GraspEnv(sensing="project", control="kinematic")
    norm = GraspEnv(sensing="project", control="kinematic", normalize=True)
    o_raw, _ = raw.reset(seed=5)
    o_norm, _ = norm.reset(seed=5)
    half = np.tile([319.0, 239.0], 6) / 2
    for key in ("achieved_goal", "desired_goal"):
        assert np.all(np.abs(o_norm[key]) <= 1.0)
        np.testing.assert_allclose((o_norm[key] + 1.0) * half, o_raw[key], rtol=0, atol=1e-9)
    assert norm.action_space.dtype == np.float32 and np.all(norm.action_space.high == 1.0)
    raw.close()
    norm.close()


def test_tool_perturbation_moves_the_hand_markers_along_the_tool_axis():
    env = GraspEnv(sensing="project", control="kinematic")
    env.reset(seed=2)
    env.set_joints(env.target_joints)
    before = env.data.geom_xpos[env.effector_geom_ids].copy()  # (3, 3)
    axis = env.effector_pose()[:3, 2]
    env.perturb({"tool": 0.02})
    env.set_joints(env.target_joints)
    np.testing.assert_allclose(
        env.data.geom_xpos[env.effector_geom_ids], before + 0.02 * axis, atol=1e-12
    )
    env.close()


def test_rgb_array_and_pixel_observations():
    env = GraspEnv(
        sensing="project", control="kinematic", render_mode="rgb_array", obs_mode="state_pixels"
    )
    obs, _ = env.reset(seed=1)
    assert obs["pixels_left"].shape == (84, 84, 3) and obs["observation"].shape == (6,)
    frame = env.render()
    assert frame.shape == (240, 3 * 320, 3)
    env.close()


# -- documented defaults ------------------------------------------------------------------------


def test_docstring_pins_every_argument_default():
    doc = inspect.getdoc(GraspEnv)
    arguments = doc.split("## Arguments", 1)[1]
    documented = {
        name: ast.literal_eval(default.replace("``", ""))
        for name, default in re.findall(r"^- ``(\w+)`` \((.+?)\):", arguments, flags=re.M)
    }
    signature = inspect.signature(GraspEnv.__init__).parameters
    assert documented == {n: p.default for n, p in signature.items() if n != "self"}
    assert documented["orientation_threshold"] == pytest.approx(np.radians(5.0), abs=1e-15)
    weight = float(re.search(r"``ORIENTATION_WEIGHT`` \(([\d.]+) m/rad\)", doc).group(1))
    assert weight == ORIENTATION_WEIGHT
    steps = int(re.search(r"registered default (\d+)", doc).group(1))
    assert gym.spec("PumaGrasp-v0").max_episode_steps == steps


# -- PumaReach beside the grasp task ---------------------------------------------------------

#: The reach settings that share the grasp task's machinery, and how far their sensed pixels may be
#: from the exact projection: rendered sensing's worst sighting (tests/test_stereo.py).
REACH_SETTINGS = [(6, "project", "servo"), (6, "render", "kinematic"), (3, "foveated", "servo")]
PIXEL_TOL = {"project": 1e-9, "render": 1.5, "foveated": 1.5}  # px
#: The scene writes angles with 7 significant digits (tests/test_models.py): 1e-6 rad at 1 m.
FK_TOL = 1e-6  # m


@pytest.mark.parametrize(("joints", "sensing", "control"), REACH_SETTINGS)
def test_puma_reach_senses_and_rewards_what_its_arm_does(joints, sensing, control):
    """PumaReach-v0 beside the grasp task, against references computed in this run: the DH
    forward kinematics of the joints the arm reached (the commanded ones, when kinematic), the
    exact projection of the effector and target, and the reward contract."""
    env = gym.make("PumaReach-v0", joints=joints, sensing=sensing, control=control)
    start, _ = env.reset(seed=3)
    u = env.unwrapped
    command = start["observation"] + 0.1  # a move that keeps the marker in both views
    obs, reward, _, _, info = env.step(command)
    q = u.data.qpos[:6].copy()
    if control == "kinematic":
        np.testing.assert_allclose(q[:joints], command, atol=1e-12)
    sensed_frame = 6 if joints == 6 else 4  # the tcp, or the wrist centre for joints 1-3
    effector = frames(q)[sensed_frame, :3, 3] + u.data.site("base").xpos
    np.testing.assert_allclose(info["effector_pos"], effector, atol=FK_TOL, rtol=0)
    assert info["visible"]
    tol = PIXEL_TOL[sensing]
    np.testing.assert_allclose(
        obs["achieved_goal"], u.stereo.project(info["effector_pos"])[0], atol=tol
    )
    target = u.stereo.project(info["target_pos"])[0]
    np.testing.assert_allclose(obs["desired_goal"], target, atol=tol)
    assert reward == u.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
    env.close()


def test_reach_hides_the_pose_task_geoms():
    env = gym.make("PumaReach-v0", joints=6).unwrapped
    for name in ("gripper_palm", "hand_marker_magenta", "hand_post"):
        assert env.model.geom_group[env.model.geom(name).id] == 5
    env.close()
    env = GraspEnv(sensing="project")
    for name in ("target", "marker_tcp", "marker_wrist"):
        assert env.model.geom_group[env.model.geom(name).id] == 5
    assert env.model.geom_group[env.model.geom("gripper_palm").id] == 2
    env.close()


# -- Stable-Baselines3 --------------------------------------------------------------------------


@pytest.mark.skipif(
    find_spec("stable_baselines3") is None or find_spec("torch") is None,
    reason="the rl extra is not installed (pip install -e '.[rl]', or make test-rl)",
)
def test_sb3_check_env():
    """SB3's checker (it calls compute_reward on batches) on what gym.make returns; in a child
    that imports torch before anything renders, as tests/test_rl.py does."""
    code = """
        import torch, json, warnings
        import gymnasium as gym
        import envs
        from stable_baselines3.common.env_checker import check_env
        out = []
        for kwargs in ({"sensing": "project", "control": "kinematic"},
                       {"sensing": "project", "control": "kinematic", "normalize": True},
                       {"sensing": "project", "control": "kinematic", "normalize": True,
                        "orientations": "ball:30", "action_range": "joints"}):
            env = gym.make("PumaGrasp-v0", **kwargs)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                check_env(env, warn=True, skip_render_check=True)
            out.append(sorted({str(w.message)[:200] for w in caught}))
        print(json.dumps(out))
    """
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    plain, normalized, narrow = json.loads(done.stdout.strip().splitlines()[-1])
    advice = ("symmetric and normalized", "we recommend using np.float32")
    assert [m for m in plain if not any(a in m for a in advice)] == []
    assert normalized == [] and narrow == []


def test_every_object_is_in_view_of_both_cameras():
    """Objects are drawn again until both cameras see all three markers whole: 1 000 resets,
    every marker inside both images by at least its own image radius (exact projection)."""
    env = gym.make("PumaGrasp-v0", sensing="project", control="kinematic")
    try:
        base = env.unwrapped
        env.reset(seed=20_000)
        size = np.array([base.image_width - 1.0, base.image_height - 1.0])
        for _ in range(1000):
            _, info = env.reset()
            assert info["visible_target"].all()
            points = marker_points(info["target_pose"])
            for camera in base.stereo.cameras:
                uv = camera.project(points)
                radius = camera.sphere_semi_axes(points, base.target_radius)[:, 0]
                assert np.all(uv.min(axis=1) >= radius) and np.all(
                    (size - uv).min(axis=1) >= radius
                )
    finally:
        env.close()
