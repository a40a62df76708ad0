"""The goal-env reward contract and the bounded spaces of ReachEnv.

``reward == compute_reward(achieved_goal, desired_goal, info)`` bit for bit, for every robot ×
sensing × control, over random, limit-hitting and marker-hiding moves, and on batches shaped as
HER passes them. The reward's distance term is checked against an independent triangulation (the
cameras' 3×4 projection matrices solved by ``numpy.linalg.lstsq``).
"""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (chooses the GL back-end, registers the envs)
from envs.reach import ReachEnv

SETTINGS = [("riacs", 3), ("puma560", 3), ("puma560", 6)]
SENSING = ("render", "project")
CONTROL = ("servo", "kinematic")
N_RANDOM = 4  # random moves per episode
BEYOND = 0.5  # rad past a joint limit for the limit-hitting moves
TRIANGULATION_TOL = 1e-9  # m, against the independent least-squares triangulation
PUMA_OUT_OF_VIEW = np.array([np.pi / 2, -np.pi / 2, np.pi / 2])  # wrist above both images (rad)


def _independent_point(env: ReachEnv, pixels: np.ndarray) -> np.ndarray:
    """World point (3,) from pixels (4,): each camera's P (3, 4) gives u P[2] - P[0] = 0 and
    v P[2] - P[1] = 0 on the homogeneous point; the 4×3 system is solved by lstsq."""
    rows = []
    for k, cam in enumerate(env.stereo.cameras):
        P = cam.projection_matrix()
        u, v = pixels[2 * k : 2 * k + 2]
        rows += [u * P[2] - P[0], v * P[2] - P[1]]
    A = np.array(rows)  # (4, 4)
    return np.linalg.lstsq(A[:, :3], -A[:, 3], rcond=None)[0]


def _commands(env: ReachEnv, seed: int) -> list[np.ndarray]:
    """Random moves, moves past both limits, and (PUMA, 3 joints) one that hides the marker."""
    rng = np.random.default_rng(seed)
    low, high = env.action_space.low, env.action_space.high
    out = list(rng.uniform(low, high, (N_RANDOM, env.joints)))
    out += [low - BEYOND, high + BEYOND]
    if env.robot == "puma560" and env.joints == 3:
        out.append(PUMA_OUT_OF_VIEW)
    return out


def _episode(env: ReachEnv, seed: int, hide_marker: bool):
    """Transitions (obs, reward, info) of one episode, the reset included."""
    obs, info = env.reset(seed=seed)
    out = [(obs, None, info)]
    for i, command in enumerate(_commands(env, seed)):
        if hide_marker and i == 1:  # the cameras never draw group 5: nothing green to find
            env.model.geom_group[env.model.geom(env.robot_spec.markers[env.joints]).id] = 5
        obs, reward, _, _, info = env.step(command)
        out.append((obs, reward, info))
    return out


@pytest.mark.parametrize("control", CONTROL)
@pytest.mark.parametrize("sensing", SENSING)
@pytest.mark.parametrize(("robot", "joints"), SETTINGS)
def test_step_reward_is_compute_reward_bit_for_bit(robot, joints, sensing, control):
    env = ReachEnv(robot=robot, joints=joints, sensing=sensing, control=control)
    hide = sensing == "render" and robot == "riacs"
    steps = _episode(env, seed=40, hide_marker=hide)[1:]
    unseen = 0
    for obs, reward, info in steps:
        assert type(reward) is float
        got = env.compute_reward(obs["achieved_goal"], obs["desired_goal"], info)
        assert got == reward  # bit for bit
        assert reward == info["reward_distance"] + info["reward_unseen"]
        seen = bool(info["visible_effector"].all())
        unseen += not seen
        assert info["reward_unseen"] == (0.0 if seen else -env.reach)
        assert info["is_success"] == (info["distance"] < env.success_threshold)
        pa = _independent_point(env, obs["achieved_goal"])
        pd = _independent_point(env, obs["desired_goal"])
        expected = -np.sqrt(np.sum((pa - pd) ** 2))
        assert info["reward_distance"] == pytest.approx(expected, abs=TRIANGULATION_TOL)
    if hide or (robot, joints) == ("puma560", 3):
        assert unseen > 0  # precondition: the unseen-marker branch was exercised

    # HER's batches: (N, 4) with a list or an object array of dicts, (B, N, 4), relabelled goals.
    achieved = np.array([o["achieved_goal"] for o, _, _ in steps])  # (N, 4)
    desired = np.array([o["desired_goal"] for o, _, _ in steps])  # (N, 4)
    infos = [i for _, _, i in steps]
    rewards = np.array([r for _, r, _ in steps])
    np.testing.assert_array_equal(env.compute_reward(achieved, desired, infos), rewards)
    as_array = np.array(infos, dtype=object)
    np.testing.assert_array_equal(env.compute_reward(achieved, desired, as_array), rewards)
    n = len(steps) // 2 * 2
    batch = env.compute_reward(
        achieved[:n].reshape(2, -1, 4), desired[:n].reshape(2, -1, 4), as_array[:n].reshape(2, -1)
    )
    np.testing.assert_array_equal(batch, rewards[:n].reshape(2, -1))
    relabelled = np.roll(achieved, 1, axis=0)  # goals achieved at another step
    singles = [
        env.compute_reward(a, g, i) for a, g, i in zip(achieved, relabelled, infos, strict=True)
    ]
    np.testing.assert_array_equal(env.compute_reward(achieved, relabelled, infos), singles)
    empty = env.compute_reward(np.zeros((0, 4)), np.zeros((0, 4)), [])
    assert empty.shape == (0,)
    env.close()


def test_info_none_takes_every_marker_as_seen():
    env = ReachEnv(robot="puma560", sensing="project", control="kinematic")
    env.reset(seed=41)
    obs, reward, _, _, info = env.step(PUMA_OUT_OF_VIEW)
    assert not info["visible_effector"].all() and info["reward_unseen"] == -env.reach
    got = env.compute_reward(obs["achieved_goal"], obs["desired_goal"], None)
    assert got == info["reward_distance"]
    batch = env.compute_reward(np.tile(obs["achieved_goal"], (3, 1)), obs["desired_goal"], info)
    np.testing.assert_array_equal(batch, [reward] * 3)  # one dict for the whole batch


def test_bad_goals_and_infos_are_refused_with_the_reason():
    env = ReachEnv(robot="riacs", sensing="project", control="kinematic")
    obs, info = env.reset(seed=42)
    with pytest.raises(ValueError, match=r"\(\.\.\., 4\)"):
        env.compute_reward(np.zeros(3), obs["desired_goal"], info)
    with pytest.raises(KeyError, match="visible_effector"):
        env.compute_reward(obs["achieved_goal"], obs["desired_goal"], {})
    with pytest.raises(ValueError, match="one info dict per transition"):
        env.compute_reward(np.zeros((3, 4)), np.zeros((3, 4)), [info, info])


@pytest.mark.parametrize("sensing", SENSING)
def test_normalized_spaces_keep_the_contract(sensing):
    env = ReachEnv(robot="puma560", sensing=sensing, control="servo", normalize=True)
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    obs, _ = env.reset(seed=43)
    for action in ([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], [0.2, -0.3, 0.4], [3.0, -3.0, 0.0]):
        obs, reward, _, _, info = env.step(np.array(action))
        assert env.observation_space.contains(obs)
        assert env.compute_reward(obs["achieved_goal"], obs["desired_goal"], info) == reward
        # the affine maps, written out: joints and pixels from their ranges
        inside = np.clip(action, -1, 1)
        command = env.joint_lower + (inside + 1) / 2 * (env.joint_upper - env.joint_lower)
        assert info["clipped"] == bool(np.any(np.abs(action) > 1))
        joints = env.joint_lower + (obs["observation"] + 1) / 2 * (
            env.joint_upper - env.joint_lower
        )
        np.testing.assert_allclose(joints, command, atol=2e-3)  # servo lands within 2 mrad
        size = np.tile([env.image_width - 1, env.image_height - 1], 2)
        target = np.minimum(np.maximum(env.sensed_target(), 0.0), size)  # seen, in the image
        np.testing.assert_allclose((obs["desired_goal"] + 1) / 2 * size, target)
    check_env(env, skip_render_check=True)
    env.close()


@pytest.mark.parametrize(("robot", "joints"), SETTINGS)
def test_servo_observations_stay_in_the_space_at_the_limits(robot, joints):
    """Commands at and past both limits: the raw joints overshoot, the observation does not."""
    env = ReachEnv(robot=robot, joints=joints, sensing="project", control="servo")
    obs, _ = env.reset(seed=44)
    assert env.observation_space.contains(obs)
    low, high = env.joint_lower, env.joint_upper
    overshoot = 0.0  # rad, largest excursion of qpos past a limit
    for command in (low, high, low - BEYOND, high + BEYOND, low, (low + high) / 2, high):
        obs, *_ = env.step(command)
        assert env.observation_space.contains(obs), obs
        q = env.data.qpos[env.qpos_ids]
        overshoot = max(overshoot, float(np.max(np.maximum(low - q, q - high))))
    if robot == "riacs":  # precondition: without the clip its observation would leave the space
        assert overshoot > 0  # (the PUMA's servos happen to stop inside in this episode)
    env.close()


@pytest.mark.parametrize(("robot", "joints"), SETTINGS)
def test_goal_spaces_are_the_image(robot, joints):
    env = ReachEnv(robot=robot, joints=joints, sensing="project", control="kinematic")
    space = env.observation_space["desired_goal"]
    np.testing.assert_array_equal(space.low, 0.0)
    np.testing.assert_array_equal(space.high, [319, 239, 319, 239])
    assert env.observation_space["achieved_goal"] == space
    np.testing.assert_array_equal(env.observation_space["observation"].low, env.joint_lower)


@pytest.mark.parametrize(("robot", "joints"), SETTINGS)
def test_kinematic_moves_leave_the_positions_mj_forward_gives(robot, joints):
    """The kinematic fast path (mj_kinematics + mj_camlight) against a full mj_forward."""
    env = ReachEnv(robot=robot, joints=joints, sensing="project", control="kinematic")
    env.reset(seed=45)
    env.step(env.action_space.sample())
    fresh = mujoco.MjData(env.model)
    fresh.qpos[:], fresh.mocap_pos[:] = env.data.qpos, env.data.mocap_pos
    mujoco.mj_forward(env.model, fresh)
    for name in ("xpos", "xmat", "site_xpos", "geom_xpos", "geom_xmat", "cam_xpos", "cam_xmat"):
        np.testing.assert_array_equal(getattr(env.data, name), getattr(fresh, name), err_msg=name)
