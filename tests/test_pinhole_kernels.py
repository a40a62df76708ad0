"""The env's per-transition arithmetic (project sensing, the reach reward, the action check):
each compiled kernel (extra ``fast``) against its numpy path bit for bit, and both against
independent formulas (the matrix projection, the ground-truth points)."""

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs import kernels as env_kernels
from envs.reach import ReachEnv
from envs.reward import GoalPoints, goal_distances
from envs.sensing import pinhole_kernels
from envs.sensing.sensors import sight
from envs.sensing.triangulation import camera_floats

compiled = pytest.mark.skipif(
    not pinhole_kernels.available(), reason="numba is not installed (pip install -e '.[fast]')"
)


def numpy_path(monkeypatch, function, *args):
    """``function(*args)`` with the kernels switched off: the numpy path."""
    monkeypatch.setattr(pinhole_kernels, "ENABLED", False)
    try:
        return function(*args)
    finally:
        monkeypatch.undo()


def same_bits(a, b) -> bool:
    return np.asarray(a).tobytes() == np.asarray(b).tobytes()


@pytest.fixture(scope="module")
def puma() -> ReachEnv:
    env = ReachEnv(robot="puma560", sensing="project", control="kinematic")
    env.reset(seed=0)
    return env


def points_around(env: ReachEnv, n: int, seed: int) -> np.ndarray:
    """World points (n, 3): most in the workspace, some far outside and behind the cameras."""
    rng = np.random.default_rng(seed)
    inside = env.robot_spec.workspace.sample(rng, n - n // 4)
    outside = rng.uniform(-6.0, 6.0, (n // 4, 3))
    cameras = np.array([c.position for c in env.stereo.cameras])
    return np.concatenate([inside, outside, cameras])  # the camera centres: depth 0


def test_sight_is_the_matrix_projection_and_its_visibility_rule(puma):
    stereo = puma.stereo
    points = points_around(puma, 400, 1)
    pixels, visible = sight(
        stereo.pixel_projections, points, np.arange(len(points)), *stereo.pixel_max
    )
    pixels, visible = pixels.reshape(-1, 4), visible.reshape(-1, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        uv, depth = stereo.project_with_depth(points)  # p @ P: another order of the sums
    uv = uv.reshape(-1, 2, 2)
    size = np.array([stereo.width - 1, stereo.height - 1])
    expected = (depth > 0) & np.all((uv >= 0) & (uv <= size), axis=-1)
    near_edge = np.any(np.abs(uv - np.clip(uv, 0, size)) < 1e-6, axis=-1)  # rounding decides
    assert np.array_equal(visible[~near_edge], expected[~near_edge])
    assert 0 < visible.mean() < 1  # both outcomes occur
    np.testing.assert_allclose(pixels.reshape(-1, 2, 2)[visible], uv[visible], rtol=0, atol=1e-9)
    assert np.isnan(pixels.reshape(-1, 2, 2)[~visible]).all()


@compiled
def test_sight_kernel_is_the_numpy_path_bit_for_bit(puma, monkeypatch):
    stereo = puma.stereo
    points = points_around(puma, 400, 2)
    args = (stereo.pixel_projections, points, np.arange(len(points)), *stereo.pixel_max)
    fast = sight(*args)
    reference = numpy_path(monkeypatch, sight, *args)
    assert same_bits(fast[0], reference[0]) and same_bits(fast[1], reference[1])


def test_goal_distances_are_those_of_the_points_seen(puma, monkeypatch):
    stereo = puma.stereo
    rng = np.random.default_rng(3)
    achieved_points = puma.robot_spec.workspace.sample(rng, 300)
    desired_points = puma.robot_spec.workspace.sample(rng, 300)
    achieved, desired = stereo.project(achieved_points).T, stereo.project(desired_points).T
    goals = GoalPoints(tuple(camera_floats(c) for c in stereo.cameras), stereo.camera_rows)
    truth = np.linalg.norm(achieved_points - desired_points, axis=1)
    fast = goal_distances(goals, achieved, desired)
    reference = numpy_path(monkeypatch, goal_distances, goals, achieved, desired)
    for distances in (fast, reference):
        np.testing.assert_allclose(distances, truth, rtol=0, atol=1e-9)


@compiled
def test_goal_distance_and_triangulation_kernels_are_the_numpy_paths_bit_for_bit(puma, monkeypatch):
    stereo = puma.stereo
    rng = np.random.default_rng(4)
    achieved = rng.uniform(0, 320, (4, 500))  # any pixels, not only consistent ones
    desired = rng.uniform(0, 240, (4, 500))
    goals = GoalPoints(tuple(camera_floats(c) for c in stereo.cameras), stereo.camera_rows)
    fast = goal_distances(goals, achieved, desired)
    assert same_bits(fast, numpy_path(monkeypatch, goal_distances, goals, achieved, desired))
    for normalized in (False, True):
        q = achieved.T / (320.0 if normalized else 1.0)
        points = stereo.triangulate(q, normalized)
        assert same_bits(points, numpy_path(monkeypatch, stereo.triangulate, q, normalized))


@compiled
@pytest.mark.parametrize("normalize", [False, True])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_action_kernel_is_the_numpy_path_bit_for_bit(normalize, dtype):
    env = ReachEnv(robot="riacs", sensing="project", control="kinematic", normalize=normalize)
    low, high = env.action_space.low, env.action_space.high
    span = high - low
    rng = np.random.default_rng(5)
    for _ in range(300):
        action = rng.uniform(low - 0.3 * span, high + 0.3 * span).astype(dtype)  # some clipped
        if rng.random() < 0.2:
            action[rng.integers(len(action))] = rng.choice([np.nan, np.inf, -np.inf])
        command = np.empty(env.joints)
        bad, clipped = env_kernels.clip_command(
            action, env._action_mid, env._action_half, env.action_lower, env.action_upper,
            normalize, command,
        )  # fmt: skip
        bad_ref, command_ref, clipped_ref = env._clipped_numpy(action)
        assert bad == bad_ref
        if bad < 0:
            assert same_bits(command, command_ref) and clipped == clipped_ref
            lo, hi = (-1.0, 1.0) if normalize else (low, high)  # the action space's bounds
            assert clipped == bool(np.any((action < lo) | (action > hi)))


@compiled
@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaReach-v0"])
@pytest.mark.parametrize("normalize", [False, True])
def test_an_episode_stream_is_the_same_bits_with_and_without_the_kernels(
    env_id, normalize, monkeypatch
):
    def stream() -> list[bytes]:
        env = gym.make(env_id, sensing="project", control="kinematic", normalize=normalize)
        observation, info = env.reset(seed=7)
        space, rng, out = env.action_space, np.random.default_rng(8), []
        for step in range(200):
            if step % 4 == 0:
                observation, info = env.reset()
            observation, reward, _, _, info = env.step(rng.uniform(space.low * 1.2, space.high))
            relabelled = env.unwrapped.compute_reward(
                observation["achieved_goal"], observation["desired_goal"], info
            )
            assert relabelled == reward  # HER's reward is the step's
            values = [*observation.values(), reward, info["distance"], info["visible_effector"]]
            out += [np.asarray(v).tobytes() for v in values]
        env.close()
        return out

    fast = stream()
    assert fast == numpy_path(monkeypatch, stream)
