"""Changes of the scene at run time (envs.perturb): each moves what it says, rendering and
projection stay consistent, the baselines keep the nominal cameras, bad changes change nothing."""

import numpy as np
import pytest

from envs.cli.controllers import make_controller
from envs.perturb import Perturbation, PerturbationError
from envs.reach import ReachEnv
from models import puma560, riacs

RENDER_TOL = 0.5  # px: rendered sensing vs exact projection (as tests/test_stereo.py)
#: The model arrays a perturbation writes.
MODEL_FIELDS = (
    "cam_pos",
    "cam_quat",
    "cam_intrinsic",
    "cam_fovy",
    "site_pos",
    "geom_pos",
    "body_pos",
)
XML_TOL = 1e-4  # px: the scene's sensor size is written with 8 digits
# The RIACS cameras (scene.xml): 78 px per unit of normalised coordinate; principal points.
RIACS_F = 78.0  # px
RIACS_POS = np.array([[0.3, 0.0, 1.0], [-0.3, 0.0, 1.0]])  # m, looking down -z, x right, y up


def _riacs_pixels(point: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Pinhole of the RIACS report's cameras, written out: x = (X - cx)/(cz - Z), y likewise;
    u = c_u + f x, v = c_v - f y. Both cameras share c_v."""
    c_v = 119.5 + 1.275 * RIACS_F
    c_u = (159.5 - 0.16 * RIACS_F, 159.5 - 2.07 * RIACS_F)
    out = []
    for k, c in enumerate(positions):
        depth = c[2] - point[2]
        out += [
            c_u[k] + RIACS_F * (point[0] - c[0]) / depth,
            c_v - RIACS_F * (point[1] - c[1]) / depth,
        ]
    return np.array(out)


@pytest.fixture
def riacs_env():
    env = ReachEnv(robot="riacs", sensing="project", control="kinematic")
    yield env
    env.close()


def test_camera_translation_shifts_the_projection_as_the_pinhole_predicts(riacs_env):
    point = np.array([0.35, 0.42, 0.1])
    np.testing.assert_allclose(
        riacs_env.stereo.project(point)[0], _riacs_pixels(point, RIACS_POS), atol=XML_TOL
    )
    shift = np.array([[0.03, -0.02, 0.05], [-0.04, 0.01, -0.03]])
    riacs_env.perturb({"camera_shift": shift})
    np.testing.assert_allclose(
        riacs_env.stereo.project(point)[0], _riacs_pixels(point, RIACS_POS + shift), atol=XML_TOL
    )
    back = riacs_env.stereo.triangulate(riacs_env.stereo.project(point))
    np.testing.assert_allclose(back[0], point, atol=1e-9)


@pytest.mark.parametrize("robot", ["riacs", "puma560"])
def test_rendering_follows_a_moved_turned_zoomed_camera(robot):
    env = ReachEnv(robot=robot, sensing="render", control="kinematic")
    env.perturb(
        {
            "camera_shift": [0.05, 0.0, 0.0],
            "camera_turn": [[0, np.deg2rad(3), 0], [np.deg2rad(-3), 0, 0]],
            "zoom": 1.05,
        }
    )
    env.reset(seed=4)
    gaps = []
    for _ in range(4):
        _, info = env.reset()
        gaps.append(np.abs(env.sensed_target() - env.stereo.project(info["target_pos"])[0]).max())
    env.close()
    assert max(gaps) < RENDER_TOL, gaps


@pytest.mark.parametrize("robot", ["riacs", "puma560"])
def test_zoom_scales_image_offsets_about_the_principal_point(robot):
    env = ReachEnv(robot=robot, sensing="project", control="kinematic")
    points = env.robot_spec.workspace.sample(np.random.default_rng(1), 20)
    before = env.stereo.project(points)
    centres = np.concatenate([c.center for c in env.stereo.cameras])  # (4,)
    env.perturb({"zoom": 1.05})
    np.testing.assert_allclose(
        env.stereo.project(points) - centres, 1.05 * (before - centres), atol=1e-6
    )
    env.close()


def test_riacs_tool_extension_is_a_longer_link_2(riacs_env):
    riacs_env.perturb({"tool": 0.05})
    riacs_env.reset(seed=0)
    q = np.array([0.4, 0.3, 2.0])
    _, _, _, _, info = riacs_env.step(q)
    expected = riacs.robot3df(riacs.LINK1, riacs.LINK2 + 0.05, *q)
    np.testing.assert_allclose(info["effector_pos"], expected, atol=1e-9)
    np.testing.assert_allclose(
        riacs_env.sensed_effector(), riacs_env.stereo.project(expected)[0], atol=1e-9
    )


def test_puma_marker_moves_along_the_forearm():
    env = ReachEnv(robot="puma560", sensing="project", control="kinematic")
    env.perturb({"tool": 0.05})
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([1.2, -0.6, 2.4]))
    elbow = env.data.xpos[env.model.body("link4").id]  # frame-3 origin shifted by a3: forearm start
    axis = env.data.xmat[env.model.body("link4").id].reshape(3, 3)[:, 2]
    np.testing.assert_allclose(
        info["effector_pos"], elbow + (puma560.kinematics.D4 + 0.05) * axis, atol=1e-9
    )
    env.close()


def test_base_shift_moves_the_arm_and_the_targets(riacs_env):
    q = np.array([0.7, 0.4, 1.5])
    riacs_env.reset(seed=3)
    before = riacs_env.step(q)[4]["effector_pos"]
    shift = np.array([0.03, -0.02, 0.01])
    riacs_env.perturb({"base_shift": shift})
    _, info = riacs_env.reset(seed=3)
    after = riacs_env.step(q)[4]
    np.testing.assert_allclose(after["effector_pos"], before + shift, atol=1e-12)
    assert riacs.WORKSPACE.contains(info["target_pos"] - shift)


def test_baselines_keep_the_nominal_cameras(riacs_env):
    point = np.array([0.3, 0.5, 0.0])
    nominal_pixels = riacs_env.stereo.project(point)
    riacs_env.perturb({"camera_shift": [0.05, 0.0, 0.0]})
    analytic = make_controller("analytic", riacs_env)
    np.testing.assert_allclose(analytic.triangulate(nominal_pixels)[0], point, atol=1e-9)
    np.testing.assert_allclose(riacs_env.nominal_stereo.project(point), nominal_pixels, atol=1e-12)
    assert np.linalg.norm(riacs_env.stereo.triangulate(nominal_pixels)[0] - point) > 0.01
    # Restoring the nominal scene restores the live cameras exactly.
    riacs_env.perturb(None)
    np.testing.assert_allclose(riacs_env.stereo.project(point), nominal_pixels, atol=1e-9)


@pytest.mark.parametrize(
    "bad",
    [
        {"camera_shift": [np.nan, 0.0, 0.0]},
        {"camera_turn": [[0.8, 0.0, 0.0], [0.0, 0.0, 0.0]]},  # 46°: workspace out of view
        {"zoom": 3.0},  # out of the accepted range
        {"zoom": 1.9},  # in range, but the workspace no longer fits the image
        {"tool": np.inf},
        {"base_shift": [0.0, 0.0, 0.6]},
        {"wobble": 1.0},
    ],
)
def test_bad_perturbations_raise_before_anything_changes(riacs_env, bad):
    riacs_env.perturb({"camera_shift": [0.01, 0.0, 0.0], "tool": 0.02})
    model = riacs_env.model
    state = [getattr(model, name).copy() for name in MODEL_FIELDS]
    pixels = riacs_env.stereo.project(np.array([0.3, 0.5, 0.0]))
    current = riacs_env.perturbation
    with pytest.raises(PerturbationError):
        riacs_env.perturb(bad)
    after = [getattr(model, name) for name in MODEL_FIELDS]
    for a, b in zip(state, after, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(riacs_env.stereo.project(np.array([0.3, 0.5, 0.0])), pixels)
    assert riacs_env.perturbation is current


def test_random_changes_have_the_asked_sizes_and_follow_the_seed(riacs_env):
    sizes = {
        "camera_shift": 0.05,
        "camera_turn": np.deg2rad(3),
        "zoom": 0.05,
        "tool": 0.05,
        "base_shift": 0.02,
    }
    a = riacs_env.perturb(random=sizes, seed=7)
    b = Perturbation.random(np.random.default_rng(7), **sizes)
    np.testing.assert_array_equal(a.camera_shift, b.camera_shift)
    np.testing.assert_allclose(np.linalg.norm(a.camera_shift, axis=1), 0.05)
    np.testing.assert_allclose(np.linalg.norm(a.camera_turn, axis=1), np.deg2rad(3))
    assert abs(a.zoom - 1) == pytest.approx(0.05) and abs(a.tool) == pytest.approx(0.05)
    np.testing.assert_allclose(np.linalg.norm(a.base_shift), 0.02)


def test_reset_option_applies_a_change(riacs_env):
    riacs_env.reset(seed=0, options={"perturb": {"zoom": 1.05}})
    assert riacs_env.perturbation.zoom == 1.05
