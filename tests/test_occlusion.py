"""A partly hidden marker sphere is located from the visible part of its outline."""

import mujoco
import numpy as np
import pytest

from envs.sensing.marker_detection import GREEN_EFFECTOR
from envs.sensing.marker_fit import MAX_HIDDEN, MAX_HIDDEN_SLIVER, outline_arc
from envs.sensing.stereo import StereoRig

RADIUS = 0.05  # m: about 16 px in these 320x240 images
#: Two cameras 1 m above the sphere, like the RIACS rig; an occluder in the robot's geom group
#: (2) just above it, moved by its mocap body; the sphere in the marker group (4), off-axis.
SCENE = f"""
<mujoco>
  <visual><global offwidth="640" offheight="240"/></visual>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="3 3 0.1" pos="0 0 -0.3" rgba="0.55 0.6 0.68 1"/>
    <camera name="cam_left" pos="0.3 0 1" fovy="40"/>
    <camera name="cam_right" pos="-0.3 0 1" fovy="40"/>
    <geom name="marker" type="sphere" size="{RADIUS}" pos="0.07 0.04 0" group="4"
      rgba="0.1 0.9 0.1 1" contype="0" conaffinity="0"/>
    <body name="occluder" mocap="true" pos="0 0 5">
      <geom name="bar" type="box" size="0.2 0.2 0.005" group="2" rgba="0.85 0.85 0.82 1"
        contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>
"""
CENTRE = np.array([0.07, 0.04, 0.0])
FAR = np.array([0.0, 0.0, 5.0])  # the occluder out of every view


@pytest.fixture(scope="module")
def rig():
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    stereo = StereoRig(model, data)
    yield model, data, stereo
    stereo.close()


def _marker_pixels(stereo, data) -> np.ndarray:
    """(2,) green pixels per camera in the full render."""
    views = stereo.render_views(data, (0, 2, 4))
    return np.array([(GREEN_EFFECTOR.mask(rgb) > 0).sum() for rgb, _ in views])


def _hidden_and_sensed(model, data, stereo, occluder_pos, size=None):
    if size is not None:
        model.geom_size[model.geom("bar").id] = size
    data.mocap_pos[0] = FAR
    mujoco.mj_forward(model, data)
    whole = _marker_pixels(stereo, data)
    data.mocap_pos[0] = occluder_pos
    mujoco.mj_forward(model, data)
    hidden = 1.0 - _marker_pixels(stereo, data) / whole
    pixels, visible = stereo.sense(data, GREEN_EFFECTOR, RADIUS)
    return hidden, pixels, visible


def test_an_unhidden_marker_is_found_at_its_projection(rig):
    model, data, stereo = rig
    hidden, pixels, visible = _hidden_and_sensed(model, data, stereo, FAR)
    assert visible.all() and np.all(hidden == 0)
    np.testing.assert_allclose(pixels, stereo.project(CENTRE[None])[0], atol=0.15)


@pytest.mark.parametrize("direction", [(1.0, 0.0), (0.0, 1.0), (-0.6, 0.8)])
def test_a_straight_edge_occluder_up_to_the_documented_fraction(rig, direction):
    """A plate slid over the sphere from one side: centre within 0.5 px of the projection while
    at most MAX_HIDDEN - 0.05 of its image is hidden, not visible beyond MAX_HIDDEN + 0.1."""
    model, data, stereo = rig
    expected = stereo.project(CENTRE[None])[0]
    d = np.array([*direction, 0.0])
    seen_fractions = []
    for edge in np.linspace(0.09, -0.07, 17):  # plate edge from the sphere's centre, m
        pos = CENTRE + np.array([0, 0, 0.1]) + (0.2 + edge) * d  # plate just above the sphere
        hidden, pixels, visible = _hidden_and_sensed(model, data, stereo, pos, (0.2, 0.2, 0.005))
        for k in range(2):
            if hidden[k] <= MAX_HIDDEN - 0.05:
                assert visible[k], f"camera {k}: {hidden[k]:.2f} hidden, not found"
                error = np.hypot(*(pixels[2 * k : 2 * k + 2] - expected[2 * k : 2 * k + 2]))
                assert error <= 0.5, f"camera {k}: {hidden[k]:.2f} hidden, {error:.2f} px off"
                seen_fractions.append(hidden[k])
            elif hidden[k] >= MAX_HIDDEN + 0.1:
                assert not visible[k], f"camera {k}: {hidden[k]:.2f} hidden, still reported"
    assert max(seen_fractions) > 0.3  # the sweep really covered partly hidden markers


def test_a_thin_bar_across_the_marker_does_not_hide_it(rig):
    model, data, stereo = rig
    pos = CENTRE + np.array([0.0, 0.0, 0.1])
    hidden, pixels, visible = _hidden_and_sensed(model, data, stereo, pos, (0.2, 0.004, 0.005))
    assert np.all(hidden > 0.1) and visible.all()
    np.testing.assert_allclose(pixels, stereo.project(CENTRE[None])[0], atol=0.5)


def test_a_sliver_beside_a_camera_that_sees_the_marker():
    """A plate slid across the left camera's view only (half-way between it and the sphere):
    the left camera's centre stays within 0.5 px of the projection while a sliver of at least
    1 - MAX_HIDDEN_SLIVER + 0.03 is visible (its outline arc then exceeds MIN_SLIVER_ARC), and is
    not reported once less than 1 - MAX_HIDDEN_SLIVER - 0.01 is visible."""
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    stereo = StereoRig(model, data)
    expected = stereo.project(CENTRE[None])[0]
    sight = (CENTRE + np.array([0.3, 0.0, 1.0])) / 2  # on the left camera's ray, half-way
    seen_slivers = []
    for edge in np.linspace(0.01, -0.03, 41):  # plate edge from that ray, m (cone radius ~0.025)
        pos = sight + np.array([0.2 + edge, 0.0, 0.0])  # the plate covers x > sight + edge
        hidden, pixels, visible = _hidden_and_sensed(model, data, stereo, pos, (0.2, 0.2, 0.005))
        assert hidden[1] == 0 and visible[1]
        error = np.hypot(*(pixels - expected).reshape(2, 2).T)
        assert error[1] <= 0.5
        if hidden[0] <= MAX_HIDDEN_SLIVER - 0.03:
            assert visible[0], f"{hidden[0]:.3f} hidden, not found"
            assert error[0] <= 0.5, f"{hidden[0]:.3f} hidden, {error[0]:.2f} px off"
            if hidden[0] > MAX_HIDDEN:
                seen_slivers.append(hidden[0])
        elif hidden[0] >= MAX_HIDDEN_SLIVER + 0.01:
            assert not visible[0], f"{hidden[0]:.3f} hidden, still reported"
    stereo.close()
    assert len(seen_slivers) >= 2  # the sweep really crossed slivers


def test_outline_arc_of_points_on_a_known_arc():
    class Camera:  # the centre's image at pixel (100, 50)
        def project(self, points):
            return np.array([[100.0, 50.0]])

    for span in (0.5, 2.0, 5.0):
        angles = np.linspace(1.0, 1.0 + span, 40)
        uv = np.array([100.0, 50.0]) + 7.0 * np.column_stack([np.cos(angles), np.sin(angles)])
        assert outline_arc(Camera(), np.zeros(3), uv) == pytest.approx(span)
