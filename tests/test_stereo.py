"""StereoRig of both scenes: projection against independent pinholes, triangulation, and rendered
sensing against exact projection.

The reference formulas are written here from the camera definitions (the RIACS report's camera()
model, MuJoCo's fovy camera), not taken from ``envs.sensing.stereo``.
"""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import envs  # noqa: F401  (chooses the GL back-end, registers the envs)
from envs.reach import IMAGE_HEIGHT, IMAGE_WIDTH, ReachEnv
from envs.sensing.marker_detection import RED_TARGET
from models import puma560, riacs

ROBOTS = ("riacs", "puma560")
N_POINTS = 200  # random world points per projection test
N_CONFIGS = 100  # random arm poses and targets per render-vs-project test
TRIANGULATION_TOL = 1e-9  # m
PROJECTION_TOL = 1e-9  # px or normalised units
MEAN_PIXEL_TOL = 0.5  # px: render sensing vs exact projection, mean over visible sightings
MAX_PIXEL_TOL = 1.5  # px: ... worst sighting
MIN_VISIBLE_FRACTION = 0.8  # configurations whose effector marker both cameras must see
N_OBLIQUE_CANDIDATES, N_OBLIQUE = 20000, 10  # workspace points drawn, most oblique kept
MIN_OBLIQUE_DEG = 70.0  # the RIACS workspace reaches ~75° off axis
RIACS_FOCAL, RIACS_HALF_SEPARATION = 1.0, 0.3  # camera(f, d) of the report


@pytest.fixture(scope="module", params=ROBOTS)
def env(request):
    """A render-sensing, kinematic env (the rig is the same for every sensing mode)."""
    e = ReachEnv(robot=request.param, sensing="render", control="kinematic")
    e.reset(seed=0)
    yield e
    e.close()


def _workspace_points(robot: str, n: int, seed: int) -> np.ndarray:
    ws = puma560.WORKSPACE if robot == "puma560" else riacs.WORKSPACE
    return ws.sample(np.random.default_rng(seed), n)  # (n, 3)


def _reaching_pose(robot: str, point: np.ndarray) -> np.ndarray:
    """Joint angles (3,) that put the sensed point at ``point`` (the arm as the task uses it)."""
    if robot == "riacs":
        return np.array(riacs.robot3dinv(riacs.LINK1, riacs.LINK2, *point))
    theta, reachable = puma560.wrist_ik(point - puma560.BASE_POS, arm=1, elbow=1)
    assert reachable
    return theta


# -- projection ---------------------------------------------------------------------------------


def test_riacs_normalized_projection_is_the_report_camera():
    """project(p, normalized=True) = camera(1, 0.3, x, y, z) of RIACS TR 90.28, both derived."""
    e = ReachEnv(robot="riacs", sensing="project", control="kinematic")
    p = _workspace_points("riacs", N_POINTS, seed=1)
    got = e.stereo.project(p, normalized=True)  # (N, 4)
    report = np.stack(riacs.camera(RIACS_FOCAL, RIACS_HALF_SEPARATION, *p.T), axis=-1)
    # Re-derived: pinhole k at (±d, 0, f) looking down -z, image x = world x, image y = world y;
    # normalised coordinate = lateral offset / distance in front of the pinhole.
    pinholes = np.array([[RIACS_HALF_SEPARATION, 0.0, RIACS_FOCAL], [-RIACS_HALF_SEPARATION, 0, 1]])
    derived = np.concatenate(
        [(p[:, :2] - c[:2]) / (c[2] - p[:, 2:3]) * RIACS_FOCAL for c in pinholes], axis=-1
    )
    np.testing.assert_allclose(got, report, rtol=0, atol=PROJECTION_TOL)
    np.testing.assert_allclose(got, derived, rtol=0, atol=PROJECTION_TOL)


def test_puma_pixel_projection_is_an_independent_fovy_pinhole():
    """PUMA cameras (fovy): P = K [Rᵀ | -Rᵀc] from model.cam_fovy, data.cam_xpos, data.cam_xmat."""
    e = ReachEnv(robot="puma560", sensing="project", control="kinematic")
    p = _workspace_points("puma560", N_POINTS, seed=2)
    got = e.stereo.project(p)  # (N, 4)
    expected = []
    for name in ("cam_left", "cam_right"):
        cid = e.model.camera(name).id
        # MuJoCo: fovy is the vertical field of view; pixels are square; the optical axis hits
        # the image centre, which is (W-1)/2, (H-1)/2 in pixel-centre (array index) coordinates.
        f = (IMAGE_HEIGHT / 2) / np.tan(np.deg2rad(e.model.cam_fovy[cid]) / 2)
        K = np.array([[f, 0, (IMAGE_WIDTH - 1) / 2], [0, f, (IMAGE_HEIGHT - 1) / 2], [0, 0, 1]])
        R = e.data.cam_xmat[cid].reshape(3, 3)  # columns: camera right, up, backwards
        flip = np.diag([1.0, -1.0, -1.0])  # camera frame -> (right, down, forward)
        P = K @ flip @ np.hstack([R.T, -R.T @ e.data.cam_xpos[cid][:, None]])  # (3, 4)
        h = np.hstack([p, np.ones((len(p), 1))]) @ P.T  # (N, 3) homogeneous pixels
        expected.append(h[:, :2] / h[:, 2:3])
    np.testing.assert_allclose(got, np.hstack(expected), rtol=0, atol=1e-6)


@pytest.mark.parametrize("robot", ROBOTS)
def test_triangulate_inverts_project(robot):
    e = ReachEnv(robot=robot, sensing="project", control="kinematic")
    p = _workspace_points(robot, N_POINTS, seed=3)
    back = e.stereo.triangulate(e.stereo.project(p))
    assert back.shape == p.shape
    np.testing.assert_allclose(back, p, rtol=0, atol=TRIANGULATION_TOL)
    normalized = e.stereo.project(p, normalized=True)
    np.testing.assert_allclose(
        e.stereo.triangulate(normalized, normalized=True), p, rtol=0, atol=TRIANGULATION_TOL
    )


def test_riacs_triangulation_matches_report_camerafd():
    """camerafd() of the report is a second stereo reconstruction: both must agree."""
    e = ReachEnv(robot="riacs", sensing="project", control="kinematic")
    p = _workspace_points("riacs", N_POINTS, seed=4)
    q = e.stereo.project(p, normalized=True)
    report = np.stack(riacs.camerafd(RIACS_FOCAL, RIACS_HALF_SEPARATION, *q.T), axis=-1)
    np.testing.assert_allclose(e.stereo.triangulate(q, normalized=True), report, atol=1e-9)


def test_triangulate_of_a_single_point_returns_one_row():
    e = ReachEnv(robot="riacs", sensing="project", control="kinematic")
    p = np.array([0.4, 0.4, 0.2])
    np.testing.assert_allclose(e.stereo.triangulate(e.stereo.project(p)[0]), [p], atol=1e-9)


def test_a_single_point_triangulates_to_the_same_bits_as_in_a_batch():
    """One point takes the Python-float path, a batch the arrays': the same bits."""
    e = ReachEnv(robot="puma560", sensing="project", control="kinematic")
    q = np.random.default_rng(6).uniform(0, 320, (200, 4))
    q[0, 1] = np.nan
    for normalized, scale in ((False, 1.0), (True, 1 / 300)):
        batch = e.stereo.triangulate(q * scale, normalized)
        single = np.concatenate([e.stereo.triangulate(x[None] * scale, normalized) for x in q])
        np.testing.assert_array_equal(single, batch)


# -- rendered sensing ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def sightings(env):
    """Sensed marker centres vs exact projection of the ground truth, through the env's API.

    Each configuration is a reset (a random workspace target, sensed) and a kinematic move onto
    a pose that puts the sensed point at another random workspace point (RIACS: robot3dinv; PUMA:
    the right-above wrist IK, the configuration whose workspace the targets are drawn from), which
    senses the effector. Returns, per marker, the pixel errors (px) of both cameras for the
    configurations where both cameras saw it (the observation holds those pixels).
    """
    rng = np.random.default_rng(5)
    errors: dict[str, list[float]] = {"target": [], "effector": []}
    env.reset(seed=6)
    for _ in range(N_CONFIGS):
        obs, info = env.reset()
        arm_goal = _workspace_points(env.robot, 1, seed=int(rng.integers(2**31)))[0]
        obs, _, _, _, info = env.step(_reaching_pose(env.robot, arm_goal))
        np.testing.assert_allclose(info["effector_pos"], arm_goal, atol=1e-9)  # pose is right
        for name, key, goal in (
            ("target", "target_pos", "desired_goal"),
            ("effector", "effector_pos", "achieved_goal"),
        ):
            if info[f"visible_{name}"].all():
                exact = env.stereo.project(info[key])[0]
                gap = np.linalg.norm((obs[goal] - exact).reshape(2, 2), axis=1)  # (2,) px
                errors[name].extend(gap)
    return {name: np.asarray(err) for name, err in errors.items()}


def test_render_sensing_sees_the_markers(sightings):
    total = 2 * N_CONFIGS  # camera images
    assert len(sightings["target"]) == total, "every workspace target is in view, unoccluded"
    assert len(sightings["effector"]) >= MIN_VISIBLE_FRACTION * total


@pytest.mark.parametrize("marker", ["target", "effector"])
def test_render_sensing_mean_error(sightings, marker):
    err = sightings[marker]
    assert err.mean() < MEAN_PIXEL_TOL, f"{marker}: mean {err.mean():.3f} px"


@pytest.mark.parametrize("marker", ["target", "effector"])
def test_render_sensing_worst_error(sightings, marker):
    err = sightings[marker]
    assert err.max() < MAX_PIXEL_TOL, f"{marker}: worst {err.max():.3f} px"


def test_perspective_correction_at_the_most_oblique_targets():
    """RIACS targets seen ~72-74° off axis: the blob centroid is 1-4 px outward of the centre's
    projection there, so only the corrected centre agrees with the pinhole within 0.5 px."""
    e = ReachEnv(robot="riacs", sensing="render", control="kinematic")
    candidates = _workspace_points("riacs", N_OBLIQUE_CANDIDATES, seed=7)
    xy = e.stereo.project(candidates, normalized=True).reshape(-1, 2, 2)  # (N, camera, xy)
    off_axis = np.arctan(np.linalg.norm(xy, axis=-1).max(axis=-1))  # (N,) rad, worse camera
    oblique = candidates[np.argsort(off_axis)[-N_OBLIQUE:]]
    assert np.rad2deg(off_axis).max() > MIN_OBLIQUE_DEG
    data = mujoco.MjData(e.model)
    for point in oblique:
        data.mocap_pos[0] = point
        mujoco.mj_forward(e.model, data)
        sensed, seen = e.stereo.sense(data, RED_TARGET)
        assert seen.all()
        gap = np.linalg.norm((sensed - e.stereo.project(point)[0]).reshape(2, 2), axis=1)
        assert gap.max() < MEAN_PIXEL_TOL, f"{point}: {gap} px"
    e.close()


def test_sense_reports_a_marker_outside_the_images_as_not_visible(env):
    """A target moved far outside both images is not visible and gets NaN, never a guess."""
    cam = env.stereo.cameras[0]
    far = cam.position + 30.0 * cam.rotation[:, 0] - cam.rotation[:, 2]  # x_norm = 30, 1 m ahead
    data = mujoco.MjData(env.model)
    mujoco.mj_resetDataKeyframe(env.model, data, env.model.key("home").id)
    data.mocap_pos[0] = far
    mujoco.mj_forward(env.model, data)
    pixels, seen = env.stereo.sense(data, RED_TARGET)
    assert not seen.any()
    assert np.isnan(pixels).all()


@pytest.mark.parametrize("robot", ROBOTS)
def test_a_larger_image_scales_the_pinhole_and_renders_it(robot):
    """Twice the image size: pixel centres map as u' = 2u + 0.5 (index coordinates), the field
    of view unchanged; rendered sensing still agrees with the projection."""
    small = ReachEnv(robot=robot, sensing="render", control="kinematic")
    large = ReachEnv(robot=robot, sensing="render", control="kinematic", width=640, height=480)
    points = small.robot_spec.workspace.sample(np.random.default_rng(7), 50)
    np.testing.assert_allclose(
        large.stereo.project(points), 2 * small.stereo.project(points) + 0.5, atol=1e-9
    )
    large.reset(seed=3)
    target = large.data.mocap_pos[0]
    assert np.abs(large.sensed_target() - large.stereo.project(target)[0]).max() < 0.5
    for env in (small, large):
        env.close()


def test_image_size_must_be_positive_pixels():
    with pytest.raises(ValueError, match="width and height"):
        ReachEnv(width=0, height=320)


def test_coarse_floor_grid_senses_the_same(monkeypatch):
    """The sensing cameras draw the floor with a coarse lighting grid (SENSING_PLANE_GRID): the
    images differ (the floor's shading), every sighting (whole images, target and effector,
    and foveated) is bit-identical to one drawn with the scene's own fine grid."""
    from envs.sensing import stereo as stereo_module
    from envs.sensing.marker_detection import GREEN_EFFECTOR, RED_TARGET
    from envs.sensing.rendering import GROUP_ROBOT, GROUP_SCENE

    shaded_differently = False
    for env_id in ("RiacsReach-v0", "PumaReach-v0"):
        coarse = gym.make(env_id, sensing="foveated", control="kinematic").unwrapped
        with monkeypatch.context() as patch:
            patch.setattr(stereo_module, "SENSING_PLANE_GRID", None)  # the scene's own grid
            fine = gym.make(env_id, sensing="foveated", control="kinematic").unwrapped
        rng = np.random.default_rng(11)
        for _ in range(40):
            target = fine.robot_spec.workspace.sample(rng, 1)[0]
            q = rng.uniform(fine.joint_lower, fine.joint_upper)
            seen = []
            for env in (fine, coarse):
                env.data.mocap_pos[0] = target
                env.set_joints(q)
                rgb = env.stereo.render_views(env.data, (GROUP_SCENE, GROUP_ROBOT))[0][0]
                t_px, t_vis = env.stereo.sense(env.data, RED_TARGET)
                s = env.stereo.sense_sphere(env.data, GREEN_EFFECTOR, env.marker_radius)
                f_px, f_vis = env.fovea.sense(env.data, GREEN_EFFECTOR, env.marker_radius, t_px)
                seen.append((rgb, t_px, t_vis, *s, f_px, f_vis))
            shaded_differently |= not np.array_equal(seen[0][0], seen[1][0])
            for a, b in zip(seen[0][1:], seen[1][1:], strict=True):
                assert np.array_equal(a, b, equal_nan=True)
        coarse.close()
        fine.close()
    assert shaded_differently
