"""Foveated sensing: windows map back to base-image pixels exactly, and find markers where the
projection says, more precisely than whole images."""

from dataclasses import replace

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from test_occlusion import CENTRE, FAR, RADIUS, rig  # noqa: F401  (the rig fixture)

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.sensing.foveated import FoveatedSensing
from envs.sensing.marker_detection import GREEN_EFFECTOR
from envs.sensing.rendering import GROUP_MARKER, GROUP_ROBOT, GROUP_SCENE
from envs.sensing.viewports import Window

GROUPS = (GROUP_SCENE, GROUP_ROBOT, GROUP_MARKER)


def test_a_pixel_aligned_window_at_base_density_is_a_crop_of_the_whole_image(rig):  # noqa: F811
    model, data, stereo = rig
    data.mocap_pos[0] = FAR
    mujoco.mj_forward(model, data)
    whole = stereo.render_views(data, GROUPS)
    windows = [Window(69.5, 89.5, 32, 36), Window(259.5, 87.5, 40, 40)]  # edges on pixel edges
    parts = stereo.render_views(data, GROUPS, windows)
    for (image, _), (crop, _), w in zip(whole, parts, windows, strict=True):
        left, top = int(w.left + 0.5), int(w.top + 0.5)
        expected = image[top : top + w.height, left : left + w.width]
        assert expected.shape == crop.shape
        same = np.all(expected == crop, axis=-1).mean()
        assert same > 0.99, f"only {same:.3f} of the window's pixels equal the crop"
        blob = (GREEN_EFFECTOR.mask(crop) > 0).sum()
        assert blob > 100  # the marker is in the window


@pytest.mark.parametrize("density", [2.0, 4.0, 6.0])
def test_a_marker_is_found_where_the_projection_says(rig, density):  # noqa: F811
    model, data, stereo = rig
    data.mocap_pos[0] = FAR
    mujoco.mj_forward(model, data)
    projected = stereo.project(CENTRE[None])[0]
    fovea = FoveatedSensing(stereo, density=density)
    guess = projected + np.array([2.5, -1.5, -2.0, 3.0])  # a prediction a few pixels off
    pixels, visible = fovea.sense(data, GREEN_EFFECTOR, RADIUS, guess)
    assert visible.all() and fovea.fallbacks == 0
    np.testing.assert_allclose(pixels, projected, atol=0.05)


def test_a_marker_outside_its_windows_is_found_in_the_whole_images(rig):  # noqa: F811
    model, data, stereo = rig
    data.mocap_pos[0] = FAR
    mujoco.mj_forward(model, data)
    fovea = FoveatedSensing(stereo)
    projected = stereo.project(CENTRE[None])[0]
    guess = projected + np.array([-60.0, 40, -60, 40])  # same disparity, 70 px off
    pixels, visible = fovea.sense(data, GREEN_EFFECTOR, RADIUS, guess)
    assert visible.all() and fovea.fallbacks == 1
    np.testing.assert_allclose(pixels, projected, atol=0.05)


def test_foveated_whole_image_and_projection_agree_on_random_poses():
    """RIACS (a 2.6 px marker in 320x240 images): foveated sensing is within 0.05 px of the
    projection on average (0.2 px at worst), whole images within 0.2 px (0.5 px at worst)."""
    env = gym.make("RiacsReach-v0", sensing="foveated", control="kinematic").unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(4)
    errors = {"whole": [], "foveated": []}
    while len(errors["foveated"]) < 25:
        env.set_joints(rng.uniform(env.joint_lower, env.joint_upper))
        projected = env.stereo.project(env.sensed_point()[None])[0]
        whole, seen = env.stereo.sense(env.data, GREEN_EFFECTOR, env.marker_radius)
        guess = projected + rng.normal(0, 2, 4)
        fov, fov_seen = env.fovea.sense(env.data, GREEN_EFFECTOR, env.marker_radius, guess)
        if seen.all() and fov_seen.all():
            for name, px in (("whole", whole), ("foveated", fov)):
                errors[name].extend(np.hypot(*(px - projected).reshape(2, 2).T))
    env.close()
    whole, fov = np.array(errors["whole"]), np.array(errors["foveated"])
    assert fov.mean() < 0.05 and fov.max() < 0.2, (fov.mean(), fov.max())
    assert whole.mean() < 0.2 and whole.max() < 0.5, (whole.mean(), whole.max())
    assert fov.mean() < whole.mean() / 3  # 4x the pixel density: clearly finer


def test_the_foveated_env_reports_base_image_pixels():
    env = gym.make("PumaReach-v0", sensing="foveated", control="kinematic")
    obs, info = env.reset(seed=3)
    base = env.unwrapped
    command = base.model.key("ready").qpos[:3]
    obs, _, _, _, info = env.step(command)
    assert info["visible"]
    target = base.stereo.project(info["target_pos"][None])[0]
    effector = base.stereo.project(info["effector_pos"][None])[0]
    np.testing.assert_allclose(obs["desired_goal"], target, atol=0.1)
    np.testing.assert_allclose(obs["achieved_goal"], effector, atol=0.1)
    env.close()


@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaReach-v0"])
def test_windows_draw_what_whole_images_draw_about_the_marker(env_id):
    """A window skips the robot's geoms outside its frustum: at base density and on pixel edges
    it is still a crop of the whole image with the robot drawn, on random poses. Skipping the
    geoms behind the expected marker (a finite window depth) changes no sensed pixel."""
    env = gym.make(env_id, sensing="foveated", control="kinematic").unwrapped
    env.reset(seed=0)
    st, radius, groups = env.stereo, env.marker_radius, (GROUP_ROBOT, GROUP_MARKER)
    rng = np.random.default_rng(7)
    compared = 0
    while compared < 12:
        env.set_joints(rng.uniform(env.joint_lower, env.joint_upper))
        projected = st.project(env.sensed_point()[None])[0]
        if not np.all((projected > 20) & (projected < [300, 220, 300, 220])):
            continue
        whole = st.render_views(env.data, groups)
        corners = np.round(projected - 16) - 0.5  # window edges on pixel edges
        crops = [Window(corners[0], corners[1], 32, 32), Window(corners[2], corners[3], 32, 32)]
        parts = st.render_views(env.data, groups, crops)
        for (image, _), (crop, _), w in zip(whole, parts, crops, strict=True):
            left, top = int(w.left + 0.5), int(w.top + 0.5)
            expected = image[top : top + w.height, left : left + w.width]
            assert np.all(expected == crop, axis=-1).mean() > 0.99
        windows = env.fovea.windows(projected + rng.normal(0, 2, 4), radius)
        assert all(np.isfinite(w.depth) for w in windows)
        unlimited = [replace(w, depth=np.inf) for w in windows]
        near = st.sense_sphere(env.data, GREEN_EFFECTOR, radius, windows)
        every = st.sense_sphere(env.data, GREEN_EFFECTOR, radius, unlimited)
        for a, b in zip(near, every, strict=True):
            np.testing.assert_array_equal(a, b)
        compared += 1
    env.close()


def _plate_over_left_camera(model, data):
    """The rig's plate half-way along the left camera's ray to the marker, covering it whole
    from that camera and not at all from the right one."""
    sight = (CENTRE + np.array([0.3, 0.0, 1.0])) / 2  # on the left camera's ray, half-way
    data.mocap_pos[0] = sight + np.array([0.2 - 0.05, 0.0, 0.0])  # edge 5 cm past the ray
    mujoco.mj_forward(model, data)


def test_a_marker_hidden_from_one_camera_inside_its_window_is_not_looked_for_again(rig):  # noqa: F811
    """The left window shows none of the marker where the right camera's sighting puts it: no
    whole images are rendered, and they would not have found it either."""
    model, data, stereo = rig
    bar = model.geom("bar").id
    size = model.geom_size[bar].copy()
    model.geom_size[bar] = (0.2, 0.2, 0.005)
    _plate_over_left_camera(model, data)
    projected = stereo.project(CENTRE[None])[0]
    fovea = FoveatedSensing(stereo)
    guess = projected + np.array([1.0, -0.5, -1.0, 0.8])  # a prediction a pixel off
    pixels, visible = fovea.sense(data, GREEN_EFFECTOR, RADIUS, guess)
    _, seen = stereo.sense(data, GREEN_EFFECTOR, RADIUS)
    model.geom_size[bar] = size
    assert fovea.fallbacks == 0
    assert visible.tolist() == seen.tolist() == [False, True]
    np.testing.assert_allclose(pixels[2:], projected[2:], atol=0.05)


@pytest.mark.parametrize("shift", [0.3, 0.4])
def test_a_window_misplaced_along_the_other_cameras_ray_falls_back(rig, shift):  # noqa: F811
    """Expected 30 or 40 cm nearer along the right camera's ray: the right window sees the
    marker where expected, the left one is misplaced and empty; the whole images find it."""
    model, data, stereo = rig
    data.mocap_pos[0] = FAR
    mujoco.mj_forward(model, data)
    right = stereo.cameras[1].position
    ray = (CENTRE - right) / np.linalg.norm(CENTRE - right)
    guess = stereo.project((CENTRE + shift * ray)[None])[0]
    projected = stereo.project(CENTRE[None])[0]
    np.testing.assert_allclose(guess[2:], projected[2:], atol=1e-9)
    fovea = FoveatedSensing(stereo)
    windows = fovea.windows(guess, RADIUS)
    first = stereo.sense_sphere(data, GREEN_EFFECTOR, RADIUS, windows)
    assert first.visible.tolist() == [False, True] and first.blank[0]  # the case in question
    pixels, visible = fovea.sense(data, GREEN_EFFECTOR, RADIUS, guess)
    assert visible.all() and fovea.fallbacks == 1
    np.testing.assert_allclose(pixels, projected, atol=0.05)


def test_a_sphere_is_sensed_at_the_same_pixels_wherever_its_window_was_placed(rig):  # noqa: F811
    """Windows on one grid of 1/density base px: the same sphere gives the same pixels for any
    prediction inside the margin (off the grid the sub-pixel phase moves them by ~0.01 px)."""
    model, data, stereo = rig
    data.mocap_pos[0] = FAR
    mujoco.mj_forward(model, data)
    projected = stereo.project(CENTRE[None])[0]
    fovea = FoveatedSensing(stereo)
    rng = np.random.default_rng(3)
    sensed = []
    for _ in range(6):
        guess = projected + rng.uniform(-3.0, 3.0, size=4)  # inside FOVEA_MARGIN_PX
        for window in fovea.windows(guess, RADIUS):
            phase = (np.array([window.left, window.top]) + 0.5) * window.density
            np.testing.assert_allclose(phase, np.round(phase), atol=1e-9)
        pixels, visible = fovea.sense(data, GREEN_EFFECTOR, RADIUS, guess)
        assert visible.all() and fovea.fallbacks == 0
        sensed.append(pixels)
    spread = np.ptp(np.array(sensed), axis=0)
    assert spread.max() < 1e-6, f"the same sphere was sensed {spread.max():.2g} px apart"


def test_several_markers_sensed_together_as_one_by_one():
    """FoveatedSensing.sense_many (the grasp task's three markers, whole images rendered once
    for all that need them) gives bit for bit what sense gives marker by marker (each with its
    own whole images), with no more renderings and fewer where whole images are needed."""
    from envs.grasp import GraspEnv

    env = GraspEnv(sensing="foveated", control="kinematic")
    fovea, markers = env.sensor.fovea, env.markers
    fovea.stereo.reuse_renders = False  # one by one would reuse the renderings of together
    saved = 0
    for seed in range(4):
        env.reset(seed=seed)
        target = env.sensed_target()
        for joints in (env.target_joints + 0.05, env.target_joints):  # near, and at the grasp
            env.set_joints(joints)
            for colours, radius, expected in (
                (markers.target_colours, env.target_radius, None),
                (markers.effector_colours, env.marker_radius, target),
            ):
                before = fovea.stereo.renders[0]
                together = fovea.sense_many(env.data, colours, radius, expected)
                middle = fovea.stereo.renders[0]
                one_by_one = [
                    fovea.sense(
                        env.data,
                        c,
                        radius,
                        None if expected is None else expected[4 * k : 4 * k + 4],
                    )
                    for k, c in enumerate(colours)
                ]
                after = fovea.stereo.renders[0]
                assert middle - before <= after - middle
                saved += (after - middle) - (middle - before)
                for (p, v), (q, w) in zip(together, one_by_one, strict=True):
                    np.testing.assert_array_equal(p, q)
                    np.testing.assert_array_equal(v, w)
    assert saved >= 2 * 4 * 2  # the object's three whole images at least: one, not three
    env.close()
