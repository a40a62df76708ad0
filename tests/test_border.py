"""A marker cut by the image border is not seen, in rendered and in foveated sensing.

Where a sphere's image lies is computed here from MuJoCo's camera definition (pose and
``fovy``), independently of ``envs.sensing``: its extent is that of many projected points of
its surface. A sphere whose image reaches beyond an image border must not be reported in that
camera; one whose image stays clearly inside must be, at its projected centre.
"""

from __future__ import annotations

import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.sensing.foveated import FoveatedSensing
from envs.sensing.marker_detection import GREEN_EFFECTOR
from envs.sensing.stereo import StereoRig

HEIGHT, WIDTH = 240, 320  # px
RADIUS = 0.03  # m: about 10 px at DEPTH
DEPTH = 1.0  # m along the optical axis
FOVY = 40.0  # degrees
SCENE = f"""
<mujoco>
  <visual><global offwidth="640" offheight="240"/></visual>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="5 5 0.1" pos="0 0 -0.5" rgba="0.55 0.6 0.68 1"/>
    <camera name="cam_left" pos="0.3 0 1" fovy="{FOVY}"/>
    <camera name="cam_right" pos="-0.3 0 1" fovy="{FOVY}"/>
    <body name="marker" mocap="true" pos="0 0 0">
      <geom type="sphere" size="{RADIUS}" group="4" rgba="0.1 0.9 0.1 1"
        contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>
"""
#: Where the sphere's centre goes, in radii of its image beyond the border's edge (negative:
#: inside the image). Every one leaves part of the sphere inside and part outside.
STRADDLE = (-0.5, 0.0, 0.5)
#: A sphere whose image ends this far (px) inside the border is clear of it.
CLEAR_PX = 2.0
SURFACE_POINTS = 4000
SENSE_TOL_PX = 0.2  # a clear sphere is found this near its projected centre
BORDERS = ("left", "top", "right", "bottom")


def _pixels(model, data, cam: int, points: np.ndarray, size=(HEIGHT, WIDTH)) -> np.ndarray:
    """World points (n, 3) -> pixels (n, 2) of camera ``cam`` (pixel centres at integers) in
    images of ``size`` (height, width) px."""
    height, width = size
    local = (points - data.cam_xpos[cam]) @ data.cam_xmat[cam].reshape(3, 3)  # (n, 3)
    f = 0.5 * height / math.tan(math.radians(model.cam_fovy[cam]) / 2)
    u = (width / 2 - 0.5) + f * local[:, 0] / -local[:, 2]
    v = (height / 2 - 0.5) - f * local[:, 1] / -local[:, 2]
    return np.stack([u, v], axis=-1)


def _point(model, data, cam: int, uv: np.ndarray) -> np.ndarray:
    """The world point (3,) at pixel uv (2,) of camera ``cam``, DEPTH along its axis."""
    f = 0.5 * HEIGHT / math.tan(math.radians(model.cam_fovy[cam]) / 2)
    x = (uv[0] - (WIDTH / 2 - 0.5)) / f
    y = ((HEIGHT / 2 - 0.5) - uv[1]) / f
    return data.cam_xpos[cam] + DEPTH * data.cam_xmat[cam].reshape(3, 3) @ np.array([x, y, -1.0])


def _beyond(
    model, data, cam: int, centre: np.ndarray, radius: float = RADIUS, size=(HEIGHT, WIDTH)
) -> np.ndarray:
    """How far (px) the image of the sphere (``centre`` (3,) m, ``radius`` m) reaches beyond
    each border's edge (left, top, right, bottom), from its surface points' projections."""
    k = np.arange(SURFACE_POINTS) + 0.5  # a Fibonacci sphere of surface points
    z = 1.0 - 2.0 * k / SURFACE_POINTS
    phi = math.pi * (1.0 + math.sqrt(5.0)) * k
    r = np.sqrt(1.0 - z**2)
    surface = centre + radius * np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)
    uv = _pixels(model, data, cam, surface, size)
    (u_min, v_min), (u_max, v_max) = uv.min(0), uv.max(0)
    height, width = size
    return np.array([-0.5 - u_min, -0.5 - v_min, u_max - (width - 0.5), v_max - (height - 0.5)])


def _placed(model, data, cam: int, border: int, offset: float) -> np.ndarray:
    """A centre (3,) that puts the sphere's image ``offset`` image radii beyond ``border``'s
    edge (negative: inside), halfway along that border."""
    half = RADIUS * 0.5 * HEIGHT / math.tan(math.radians(FOVY) / 2) / DEPTH  # px, about
    uv = np.array([(WIDTH - 1) / 2, (HEIGHT - 1) / 2])
    axis, sign = border % 2, (-1.0 if border < 2 else 1.0)
    edge = -0.5 if border < 2 else (WIDTH, HEIGHT)[axis] - 0.5
    uv[axis] = edge + sign * offset * half
    return _point(model, data, cam, uv)


@pytest.fixture(scope="module")
def scene():
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    stereo = StereoRig(model, data, HEIGHT, WIDTH)
    yield model, data, stereo
    stereo.close()


def _sense(stereo, data, how: str, expected: np.ndarray):
    if how == "render":
        return stereo.sense(data, GREEN_EFFECTOR, RADIUS)
    fovea = FoveatedSensing(stereo)
    return fovea.sense(data, GREEN_EFFECTOR, RADIUS, None if how == "whole first" else expected)


@pytest.mark.parametrize("how", ["render", "foveated", "whole first"])
@pytest.mark.parametrize("border", range(4), ids=BORDERS)
@pytest.mark.parametrize("cam", [0, 1], ids=["left", "right"])
def test_a_sphere_cut_by_the_border_is_not_seen(scene, cam, border, how):
    model, data, stereo = scene
    for offset in STRADDLE:
        centre = _placed(model, data, cam, border, offset)
        beyond = _beyond(model, data, cam, centre)
        assert beyond[border] > 1.0 and beyond[border] < 2 * RADIUS / DEPTH * 330  # straddles
        data.mocap_pos[0] = centre
        mujoco.mj_forward(model, data)
        expected = np.concatenate([_pixels(model, data, c, centre[None])[0] for c in (0, 1)])
        pixels, visible = _sense(stereo, data, how, expected)
        where = f"{BORDERS[border]} border, offset {offset}"
        assert not visible[cam], f"{where}: seen at {pixels[2 * cam : 2 * cam + 2]}"
        assert np.isnan(pixels[2 * cam : 2 * cam + 2]).all(), where


@pytest.mark.parametrize("how", ["render", "foveated", "whole first"])
@pytest.mark.parametrize("border", range(4), ids=BORDERS)
@pytest.mark.parametrize("cam", [0, 1], ids=["left", "right"])
def test_a_sphere_clear_of_the_border_is_seen_at_its_projection(scene, cam, border, how):
    model, data, stereo = scene
    offset = -1.0  # one image radius inside, then moved until it ends CLEAR_PX inside
    centre = _placed(model, data, cam, border, offset)
    for _ in range(20):
        beyond = _beyond(model, data, cam, centre)[border]
        if beyond <= -CLEAR_PX:
            break
        offset -= 0.1
        centre = _placed(model, data, cam, border, offset)
    assert -3 * CLEAR_PX < beyond <= -CLEAR_PX  # near the border, clear of it
    data.mocap_pos[0] = centre
    mujoco.mj_forward(model, data)
    expected = np.concatenate([_pixels(model, data, c, centre[None])[0] for c in (0, 1)])
    pixels, visible = _sense(stereo, data, how, expected)
    assert visible[cam], f"{BORDERS[border]} border: not seen"
    np.testing.assert_allclose(
        pixels[2 * cam : 2 * cam + 2], expected[2 * cam : 2 * cam + 2], atol=SENSE_TOL_PX
    )


@pytest.mark.parametrize("sensing", ["render", "foveated"])
def test_puma_effector_cut_by_the_border_is_not_sensed(sensing):
    """The reported case: random kinematic moves of the PUMA from reset(seed=125); whenever the
    marker's image reaches beyond a border (by more than a pixel), that camera does not sense
    it, and the observation keeps its goals inside the image."""
    env = gym.make("PumaReach-v0", sensing=sensing, control="kinematic")
    u = env.unwrapped
    site = u.model.site(u.robot_spec.sensed[u.joints]).id
    radius = float(u.model.geom(u.robot_spec.markers[u.joints]).size[0])
    size = (u.image_height, u.image_width)
    cameras = [u.model.camera(name).id for name in ("cam_left", "cam_right")]
    env.reset(seed=125)
    env.action_space.seed(0)
    cut = 0
    for _ in range(300):
        obs, *_, truncated, _ = env.step(env.action_space.sample())
        sensed = u.sensed_effector()
        for k, cam in enumerate(cameras):
            beyond = _beyond(u.model, u.data, cam, u.data.site_xpos[site], radius, size)
            if beyond.max() > 1.0:
                cut += 1
                assert np.isnan(sensed[2 * k : 2 * k + 2]).all(), (k, beyond)
        assert np.all(obs["achieved_goal"] >= 0)
        if truncated:
            env.reset()
    env.close()
    assert cut >= 20  # the moves did cut the marker often
