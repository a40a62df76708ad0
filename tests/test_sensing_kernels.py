"""The compiled sensing kernels (extra ``fast``) against the numpy reference paths."""

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.sensing import kernels as sensing_kernels
from envs.sensing.marker_detection import GREEN_EFFECTOR, Blob, outline_edges
from envs.sensing.marker_fit import fit_centre, outline_residual_px, rays
from envs.sensing.stereo import PinholeCamera

pytestmark = pytest.mark.skipif(
    not sensing_kernels.available(), reason="numba is not installed (pip install -e '.[fast]')"
)


@pytest.fixture
def numpy_path(monkeypatch):
    """Calls with the kernels switched off: the numpy reference."""

    def call(function, *args):
        monkeypatch.setattr(sensing_kernels, "ENABLED", False)
        try:
            return function(*args)
        finally:
            monkeypatch.setattr(sensing_kernels, "ENABLED", True)

    return call


def test_outline_edges_are_the_numpy_paths_point_for_point(numpy_path):
    rng = np.random.default_rng(0)
    for shape in [(1, 1), (2, 3), (40, 31), (104, 104)]:
        rows, cols = np.mgrid[: shape[0], : shape[1]]
        disc = (rows - shape[0] / 2) ** 2 + (cols - shape[1] / 2.3) ** 2 < (shape[0] / 3) ** 2
        mask = disc | (rng.random(shape) < 0.05)  # a blob with specks
        depth = rng.uniform(1.0, 1.2, shape)  # some neighbours nearer, some farther
        blob = Blob(mask, int(mask.sum()), False)
        compiled = outline_edges(blob, depth, 0.01)
        reference = numpy_path(outline_edges, blob, depth, 0.01)
        np.testing.assert_array_equal(compiled, reference)


def test_fit_and_residuals_agree_with_the_numpy_path(numpy_path):
    """Outline rays of a known sphere seen by two cameras, with pixel noise: the compiled
    Gauss-Newton loop ends where numpy's does, the residuals are numpy's."""
    rng = np.random.default_rng(1)
    centre, radius = np.array([0.05, -0.02, -1.2]), 0.03
    focal, principal = np.array([400.0, 400.0]), np.array([159.5, 119.5])
    cams = [PinholeCamera(np.array([x, 0, 0]), np.eye(3), focal, principal) for x in (0.2, -0.2)]
    directions, points = [], []
    for cam in cams:
        axis = (centre - cam.position) / np.linalg.norm(centre - cam.position)
        alpha = np.arcsin(radius / np.linalg.norm(centre - cam.position))
        across = np.cross(axis, [0, 1.0, 0])
        across /= np.linalg.norm(across)
        other = np.cross(axis, across)
        angles = rng.uniform(0, 5.0, 60)  # part of the outline
        grazing = np.cos(alpha) * axis + np.sin(alpha) * (
            np.cos(angles)[:, None] * across + np.sin(angles)[:, None] * other
        )
        uv = cam.project(cam.position + grazing) + rng.normal(0, 0.2, (60, 2))
        points.append(uv)
        directions.append(rays(cam, uv))
    origins = [c.position for c in cams]
    start = centre + np.array([0.01, -0.01, 0.03])  # m off
    for n in (1, 2):
        compiled = fit_centre(origins[:n], directions[:n], radius, start)
        reference = numpy_path(fit_centre, origins[:n], directions[:n], radius, start)
        np.testing.assert_allclose(compiled[0], reference[0], atol=1e-9)
        assert compiled[1] == pytest.approx(reference[1], abs=1e-9)
        assert np.linalg.norm(compiled[0] - centre) < 0.005  # and it found the sphere
    for cam, uv, d in zip(cams, points, directions, strict=True):
        compiled = outline_residual_px(cam, centre, radius, uv, d)
        reference = numpy_path(outline_residual_px, cam, centre, radius, uv, d)
        np.testing.assert_allclose(compiled, reference, atol=1e-9)


def test_foveated_sensing_is_the_same_on_both_paths(numpy_path):
    """PUMA, random poses: the same sightings, pixels within 1e-6 px."""
    env = gym.make("PumaReach-v0", sensing="foveated", control="kinematic").unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(5)
    compared = 0
    while compared < 8:
        env.set_joints(rng.uniform(env.joint_lower, env.joint_upper))
        projected = env.stereo.project(env.sensed_point()[None])[0]
        if not np.all((projected > 10) & (projected < [310, 230, 310, 230])):
            continue
        guess = projected + rng.normal(0, 2, 4)
        args = (env.data, GREEN_EFFECTOR, env.marker_radius, guess)
        pixels, visible = env.fovea.sense(*args)
        ref_pixels, ref_visible = numpy_path(env.fovea.sense, *args)
        np.testing.assert_array_equal(visible, ref_visible)
        np.testing.assert_allclose(pixels, ref_pixels, atol=1e-6)
        compared += visible.any()
    env.close()
