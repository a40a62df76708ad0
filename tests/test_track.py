"""PumaTrack-v0 and the path generators: kinematics checked against independent formulas, the
env's documented contract, and tracking with exact, trained and untrained controllers."""

from __future__ import annotations

import inspect

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.harness.tracking import evaluate, exact_inverse_jacobian, track_episode, train_on_paths
from envs.track import MAX_JOINT_STEP, PumaTrackEnv
from learners.natenet import NATEnet, PathTracker
from models.paths import circle_path, path_is_valid, pose_ik, sample_path, tcp_pose
from models.puma560 import DH
from models.puma560.kinematics import jacobian
from models.rotations import matrix_to_rotvec, rotvec_to_matrix


def expm_series(rotvec: np.ndarray, terms: int = 40) -> np.ndarray:
    """exp([r]×) by its Taylor series, independent of Rodrigues' formula."""
    K = np.array(
        [[0, -rotvec[2], rotvec[1]], [rotvec[2], 0, -rotvec[0]], [-rotvec[1], rotvec[0], 0]]
    )
    out, term = np.eye(3), np.eye(3)
    for n in range(1, terms):
        term = term @ K / n
        out = out + term
    return out


@pytest.fixture(scope="module")
def env():
    e = PumaTrackEnv()
    yield e
    e.close()


def test_rotation_vector_maps():
    rng = np.random.default_rng(0)
    vectors = rng.standard_normal((20, 3))
    vectors = np.concatenate([vectors, [[np.pi - 1e-7, 0, 0], [0, 0, 1e-10], [0.0, 0.0, 0.0]]])
    for r in vectors:
        np.testing.assert_allclose(rotvec_to_matrix(r), expm_series(r), atol=1e-12)
    R = rotvec_to_matrix(vectors)
    np.testing.assert_allclose(rotvec_to_matrix(matrix_to_rotvec(R)), R, atol=1e-9)


def test_pose_ik_inverts_forward_kinematics():
    rng = np.random.default_rng(1)
    theta = rng.uniform(
        [-1.8, -2.8, -0.7, -1.0, 0.3, -2.0], [-0.8, -1.4, 0.5, 1.0, 1.4, 2.0], (50, 6)
    )
    position, rotation = tcp_pose(theta)
    solved, reachable = pose_ik(position, rotation)
    assert reachable.all()
    p2, R2 = tcp_pose(solved)
    np.testing.assert_allclose(p2, position, atol=1e-10)
    np.testing.assert_allclose(R2, rotation, atol=1e-10)


def test_circle_geometry_and_velocities():
    R0 = tcp_pose(np.array([-1.3, -2.2, 0.0, 0.2, 0.8, 0.1]))[1]
    centre, normal = np.array([0.0, 0.5, 0.7]), np.array([0.0, 0.0, 1.0])
    path = circle_path(centre, 0.1, normal, [1.0, 0.0, 0.0], R0, [0.0, 1.0, 0.0], 0.2, 100, 0.04)
    np.testing.assert_allclose(np.linalg.norm(path.positions - centre, axis=1), 0.1)
    np.testing.assert_allclose(path.positions[0], path.positions[-1], atol=1e-12)
    np.testing.assert_allclose(path.rotations[0], path.rotations[-1], atol=1e-12)
    # central differences of the samples against the analytic velocities
    fd = (path.positions[2:] - path.positions[:-2]) / (2 * path.dt)
    np.testing.assert_allclose(fd, path.linear_velocity[1:-1], atol=2e-4)
    Rdot = matrix_to_rotvec(path.rotations[2:] @ np.swapaxes(path.rotations[:-2], 1, 2))
    np.testing.assert_allclose(Rdot / (2 * path.dt), path.angular_velocity[1:-1], atol=2e-4)
    assert np.linalg.norm(path.linear_velocity[0]) == pytest.approx(2 * np.pi * 0.1 / 4.0)


@pytest.mark.parametrize("kind", ["circle", "line"])
def test_sampled_paths_are_valid_and_seeded(kind):
    a = sample_path(np.random.default_rng(7), kind)
    b = sample_path(np.random.default_rng(7), kind)
    np.testing.assert_array_equal(a.positions, b.positions)
    assert path_is_valid(a) and a.kind == kind and a.n_steps == 100
    assert np.all((a.joints >= DH.lower) & (a.joints <= DH.upper))
    np.testing.assert_allclose(tcp_pose(a.joints)[0], a.positions, atol=1e-10)


def test_check_env_passes(env):
    check_env(env, skip_render_check=True)


def test_reset_starts_on_the_path_and_senses_the_tcp(env):
    obs, info = env.reset(seed=3)
    path = env.path
    assert info["position_error"] < 1e-9 and info["orientation_error"] < 1e-6
    # MuJoCo's tcp site equals the DH forward kinematics of the joints
    p, R = tcp_pose(obs["joints"])
    np.testing.assert_allclose(info["tcp_pos_true"], p, atol=1e-9)
    np.testing.assert_allclose(obs["tcp_rot"].reshape(3, 3), R, atol=1e-9)
    np.testing.assert_allclose(obs["tcp_pos"], p, atol=1e-9)  # project + triangulate is exact
    np.testing.assert_array_equal(obs["target_pos"], path.positions[1])
    np.testing.assert_array_equal(obs["target_vel"][:3], path.linear_velocity[1])


def test_step_contract(env):
    obs, _ = env.reset(seed=4)
    obs2, reward, terminated, truncated, info = env.step(np.full(6, 1.0))
    np.testing.assert_allclose(obs2["joints"] - obs["joints"], MAX_JOINT_STEP)
    assert reward == -info["position_error"] == info["reward_position"]
    expected = np.linalg.norm(tcp_pose(obs2["joints"])[0] - env.path.positions[1])
    assert info["position_error"] == pytest.approx(expected, abs=1e-9)
    assert not terminated and not truncated
    for _ in range(env.path.n_steps - 1):
        *_, truncated, _ = env.step(np.zeros(6))
    assert truncated


def test_same_seed_same_path_and_given_path(env):
    env.reset(seed=11)
    first = env.path
    env.reset(seed=11)
    np.testing.assert_array_equal(env.path.positions, first.positions)
    env.reset(seed=12, options={"path": first})
    assert env.path is first


def test_registered_env_and_bad_actions():
    e = gym.make("PumaTrack-v0", path_kind="line")
    try:
        e.reset(seed=0)
        assert e.unwrapped.path.kind == "line"
        for bad in (np.full(6, np.nan), np.zeros(5)):
            with pytest.raises(ValueError, match="action"):
                e.unwrapped.step(bad)
    finally:
        e.close()


def test_invalid_arguments():
    with pytest.raises(ValueError, match="sensing"):
        PumaTrackEnv(sensing="lidar")
    with pytest.raises(ValueError, match="path_kind"):
        PumaTrackEnv(path_kind="spiral")


def test_render_sensing_and_frame():
    e = PumaTrackEnv(render_mode="rgb_array", sensing="render", path_kind="circle")
    try:
        obs, info = e.reset(seed=0)
        frame = e.render()
    finally:
        e.close()
    assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8
    if info["visible"]:  # detection of the green marker agrees with the truth within 5 mm
        assert np.linalg.norm(obs["tcp_pos"] - info["tcp_pos_true"]) < 5e-3


def test_exact_inverse_jacobian_tracks_to_a_tenth_of_a_millimetre(env):
    theta = np.array([-1.3, -2.2, 0.1, 0.3, 0.9, 0.2])
    np.testing.assert_allclose(
        exact_inverse_jacobian(theta) @ jacobian(theta), np.eye(6), atol=1e-9
    )
    result = track_episode(env, PathTracker(exact_inverse_jacobian), seed=21)
    assert result.position_errors.max() < 1e-4
    assert result.orientation_errors.max() < np.deg2rad(0.05)


def test_trained_net_tracks_far_better_than_untrained():
    train_env = PumaTrackEnv()
    test_env = PumaTrackEnv(path_kind="circle", circle_radius=0.1)
    try:
        net = NATEnet(input_dim=5)
        history = train_on_paths(train_env, net, range(40), 0.01, np.random.default_rng(0))
        assert history["nodes"][-1] == net.n_nodes > 1
        seeds = [500, 501]
        trained = evaluate(test_env, PathTracker.from_net(net), seeds)
        untrained = evaluate(test_env, PathTracker.from_net(NATEnet(input_dim=5)), seeds)
    finally:
        train_env.close()
        test_env.close()
    assert trained["position_mm"].mean() < untrained["position_mm"].mean() / 20
    assert trained["orientation_deg"].mean() < untrained["orientation_deg"].mean() / 5


def test_documented_defaults():
    import inspect

    from envs import track

    defaults = {
        k: v.default for k, v in inspect.signature(PumaTrackEnv.__init__).parameters.items()
    }
    assert defaults == {
        "self": inspect.Parameter.empty,
        "render_mode": None,
        "sensing": "project",
        "path_kind": "any",
        "n_steps": 100,
        "dt": 0.04,
        "circle_radius": None,
    }
    assert track.MAX_JOINT_STEP == 0.1 and track.RENDER_SIZE == (480, 640)
    assert track.SUCCESS_POSITION == 0.002 and np.degrees(track.SUCCESS_ORIENTATION) == 1.0
    for text in ("±0.1 rad", "| 100 |", "| 0.04 |", '``"project"``', '``"any"``', "2 mm", "1°"):
        assert text in PumaTrackEnv.__doc__


def test_registration_truncates_with_the_path():
    """The registered time limit is the default path length: TimeLimit and the env agree."""
    spec = gym.spec("PumaTrack-v0")
    assert spec.max_episode_steps == inspect.signature(PumaTrackEnv).parameters["n_steps"].default
    e = gym.make("PumaTrack-v0", path_kind="line")
    e.reset(seed=3)
    steps, truncated = 0, False
    while not truncated:
        *_, truncated, _ = e.step(np.zeros(6))
        steps += 1
    assert steps == spec.max_episode_steps
    e.close()
