"""The pixel cameras of ``obs_mode="pixels"``: they frame every arm's workspace (checked with a
pinhole projection written here), draw the target as large as the camera's intrinsics say,
place the marker where that projection puts it, leave the sensing cameras' images as they were,
and the framing study counts what it says."""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (registers the envs)
from envs.robots import reach_env_ids
from envs.sensing.drawn_spheres import spheres_drawn
from envs.sensing.pixel_cameras import (
    PIXEL_MARGIN,
    SPHERE_PX,
    frame_points,
    random_joints,
    sensed_points,
)
from envs.sensing.viewports import place_camera
from envs.studies.framing import Moves, framing

FAST = {"sensing": "project", "control": "kinematic"}
SIZE = 84  # px, the default image observation
TARGET_GROUP = 1
GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)


def pinhole(camera, points: np.ndarray) -> np.ndarray:
    """Pixels (N, 2) of world points (N, 3): camera coordinates x right, y up, z backwards,
    u = c_u + f x / -z, v = c_v - f y / -z."""
    local = (np.asarray(points) - camera.position) @ camera.rotation  # (N, 3)
    depth = -local[:, 2]
    assert np.all(depth > 0), "a point behind the camera"
    (fu, fv), (cu, cv) = camera.focal, camera.center
    return np.stack([cu + fu * local[:, 0] / depth, cv - fv * local[:, 1] / depth], -1)


def ellipse_centre(camera, point: np.ndarray, radius: float) -> np.ndarray:
    """(u, v) px of the centre of a sphere's image (an ellipse): at sin φ cos φ / (cos² φ -
    sin² α) from the principal point along the centre's direction, φ the centre's angle off
    the axis, α the half-angle the sphere subtends."""
    x, y, z = (np.asarray(point) - camera.position) @ camera.rotation
    distance, off = np.linalg.norm([x, y, z]), np.hypot(x, y)
    sin_phi, cos_phi, sin_a = off / distance, -z / distance, radius / distance
    r = sin_phi * cos_phi / (cos_phi**2 - sin_a**2) / max(off, 1e-12)  # per unit of (x, y)
    (fu, fv), (cu, cv) = camera.focal, camera.center
    return np.array([cu + fu * x * r, cv - fv * y * r])


def _env(env_id: str, **kwargs) -> gym.Env:
    return gym.make(env_id, obs_mode="pixels", **FAST, **kwargs)


@pytest.mark.parametrize("env_id", reach_env_ids())
def test_the_pixel_cameras_frame_markers_and_targets_with_a_margin(env_id):
    """Sensed points of random joint vectors and targets, drawn with another seed than the
    cameras were placed with, lie inside both images with most of the margin left."""
    base = _env(env_id).unwrapped
    rng = np.random.default_rng(123)
    points = np.concatenate(
        [
            sensed_points(base, random_joints(base, rng, 300)),
            base.robot_spec.workspace.sample(rng, 300),
        ]
    )
    half = (SIZE - 1) / 2
    for camera in base.pixel_rig.cameras.cameras:
        offset = np.abs(pinhole(camera, points) - half) / (SIZE / 2)  # 1: the image border
        assert offset.max() < 1 - 0.5 * PIXEL_MARGIN
        assert offset.max() > 1 - 2 * PIXEL_MARGIN  # the workspace fills the view
    base.close()


def _colour_centroid(image: np.ndarray, channel: int) -> np.ndarray:
    """(u, v) px of the pixels where ``channel`` clearly dominates (the green marker)."""
    rgb = image.astype(int)
    others = np.delete(rgb, channel, axis=-1).max(-1)
    rows, cols = np.nonzero((rgb[..., channel] > 120) & (others < 0.6 * rgb[..., channel]))
    assert len(rows) >= 9
    return np.array([cols.mean(), rows.mean()])


@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaReach-v0"])
def test_the_marker_is_drawn_where_the_pinhole_projects_it(env_id):
    env = _env(env_id)
    base = env.unwrapped
    env.reset(seed=0)
    base.data.mocap_pos[base.target_mocap_id] = [0.0, 0.0, -10.0]  # out of sight
    rng = np.random.default_rng(4)
    checked = 0
    for q in random_joints(base, rng, 6):
        base.set_joints(q)
        images = base._images.render(base.data)
        expected = [
            pinhole(c, base.sensed_point()[None])[0] for c in base.pixel_rig.cameras.cameras
        ]
        for image, uv in zip(images, expected, strict=True):
            if not np.all((uv > 4) & (uv < SIZE - 5)):
                continue
            try:
                got = _colour_centroid(image, 1)
            except AssertionError:  # hidden behind a link
                continue
            assert np.hypot(*(got - uv)) < 0.75
            checked += 1
    assert checked >= 6
    env.close()


@pytest.mark.parametrize("env_id", reach_env_ids())
def test_the_target_covers_the_disc_its_intrinsics_give(env_id):
    """On the optical axis, the target's image is a disc of radius f R / sqrt(d² - R²) px (f
    from the vertical field of view); MuJoCo's segmentation counts its pixels (a 16-facet
    sphere: within 5 %, and whole pixels: a quarter of the perimeter), at least 9 wherever the
    framed points lie."""
    base = _env(env_id).unwrapped
    rig = base.pixel_rig
    camera, view = rig.cameras.cameras[0], rig.views()[0]
    fovy = 2 * np.arctan(SIZE / 2 / camera.focal[1])  # rad, the intrinsics' own
    f = SIZE / 2 / np.tan(fovy / 2)  # px
    radius = max(base.target_radius, rig.sphere_radius)  # m, as drawn
    depths = -(frame_points(base) - camera.position) @ camera.rotation[:, 2]  # (N,) m
    renderer = mujoco.Renderer(base.model, SIZE, SIZE)
    renderer.enable_segmentation_rendering()
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[TARGET_GROUP] = 1
    counts, areas = [], []
    for distance in (depths.min(), np.median(depths), depths.max()):
        base.data.mocap_pos[base.target_mocap_id] = (
            camera.position - distance * camera.rotation[:, 2]
        )
        mujoco.mj_kinematics(base.model, base.data)
        with spheres_drawn(base.model, base.data, base.target_geom_ids, [], rig.sphere_radius):
            renderer.update_scene(base.data, camera=-1, scene_option=option)
            place_camera(renderer.scene, view)
            ids, kinds = np.moveaxis(renderer.render(), -1, 0)
        counts.append(np.count_nonzero((kinds == GEOM) & np.isin(ids, base.target_geom_ids)))
        areas.append(np.pi * (f * radius / np.sqrt(distance**2 - radius**2)) ** 2)
    renderer.close()
    areas = np.array(areas)
    ring = 0.25 * 2 * np.sqrt(np.pi * areas)  # px, a quarter of the perimeter: whole pixels
    assert np.all(np.abs(np.array(counts) - areas) <= 0.05 * areas + ring), (counts, areas)
    assert min(counts) >= 9
    assert min(areas) == pytest.approx(np.pi * SPHERE_PX**2, rel=0.01)  # at the farthest
    base.close()


@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaReach-v0"])
def test_the_sensing_cameras_see_what_they_saw_before(env_id):
    """With the marker on the target (drawn as a larger shell in the pixel views), a pixel
    observation leaves the model as it was: the sensing images equal a state env's bit for bit,
    and the marker's silhouette is centred where the sensing cameras' pinholes put it."""
    made = {mode: gym.make(env_id, obs_mode=mode, **FAST).unwrapped for mode in ("state", "pixels")}
    base = made["pixels"]
    for q in random_joints(base, np.random.default_rng(7), 50):  # the marker well inside both
        uv = base.stereo.project(sensed_points(base, q[None]))[0].reshape(2, 2)
        if np.all((uv > 10) & (uv < np.array([base.image_width, base.image_height]) - 10)):
            break
    images = {}
    for mode, base in made.items():
        base.reset(seed=2)
        base.set_joints(q)
        base.data.mocap_pos[base.target_mocap_id] = base.sensed_point()
        mujoco.mj_kinematics(base.model, base.data)
        size, rgba = base.model.geom_size.copy(), base.model.geom_rgba.copy()
        if mode == "pixels":
            base._images.render(base.data)
        np.testing.assert_array_equal(base.model.geom_size, size)
        np.testing.assert_array_equal(base.model.geom_rgba, rgba)
        images[mode] = base.stereo.render_views(base.data, (0, 2, 4))  # floor, robot, marker
    for (rgb, _), (plain, _) in zip(images["pixels"], images["state"], strict=True):
        np.testing.assert_array_equal(rgb, plain)
    base = made["pixels"]
    alone = base.stereo.render_views(base.data, (4,))  # the marker alone: its whole silhouette
    for (_, depth), camera in zip(alone, base.stereo.cameras, strict=True):
        uv = ellipse_centre(camera, base.sensed_point(), base.marker_radius)
        rows, cols = np.nonzero(depth < depth.max())
        assert len(rows) >= 9 and np.hypot(cols.mean() - uv[0], rows.mean() - uv[1]) < 0.2
    for base in made.values():
        base.close()


def test_the_framing_study_counts_each_reason():
    """Hand-made moves: inside both sensing images, the marker above the left image, the target
    behind the cameras; the study says which."""
    base = gym.make("PumaReach-v0", **FAST).unwrapped
    pair = base.stereo
    inside = pair.triangulate(np.array([[160.0, 120.0, 160.0, 120.0]]))[0]
    left = pair.cameras[0]
    above = left.position + 5.0 * (-left.rotation[:, 2]) + 5.0 * left.rotation[:, 1]
    behind = left.position + left.rotation[:, 2]  # a metre behind the left camera
    moves = Moves(
        np.zeros((3, 3)),
        np.array([inside, above, inside]),
        np.array([inside, inside, behind]),
    )
    result = framing(moves, pair, base.image_height, base.image_width)
    assert result["framed"] == pytest.approx(1 / 3)
    assert result["reasons"]["marker left top"] == pytest.approx(1 / 3)
    assert result["reasons"]["target left behind"] == pytest.approx(1 / 3)
    base.close()


@pytest.mark.filterwarnings("ignore:.*symmetric and normalized")  # radians, by design
@pytest.mark.parametrize("env_id", reach_env_ids())
def test_gymnasium_check_env_passes_on_every_arms_images(env_id):
    env = _env(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_gymnasiums_frame_stack_takes_the_dict_observation():
    """FrameStackObservation stacks every key; the last frame is the env's own observation."""
    env = gym.wrappers.FrameStackObservation(_env("RiacsReach-v0"), 3)
    obs, _ = env.reset(seed=1)
    assert obs["pixels_left"].shape == (3, SIZE, SIZE, 3) and obs["desired_goal"].shape == (3, 4)
    np.testing.assert_array_equal(obs["pixels_left"][0], obs["pixels_left"][2])  # padding
    step = env.step(env.action_space.sample())[0]
    assert env.observation_space.contains(step)
    np.testing.assert_array_equal(step["pixels_left"][1], obs["pixels_left"][2])
    assert not np.array_equal(step["pixels_left"][2], step["pixels_left"][1])  # the arm moved
    env.close()
