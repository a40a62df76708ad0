"""ArmScene, the base both arm envs share, and the sensors chosen once per sensing mode.

References are independent of the code under test: the analytic kinematics of ``models`` for the
sensed point, finite differences for its Jacobian, the array projection
(``StereoRig.project``) for projected sensing, rendered sensing within the tolerances of
tests/test_stereo.py.
"""

from __future__ import annotations

import pickle

import mujoco
import numpy as np
import pytest

import envs  # noqa: F401  (chooses the GL back-end, registers the envs)
from envs.reach import ReachEnv
from envs.scene import ArmScene
from envs.sensing.sensors import FoveatedSensor, ProjectSensor, RenderSensor, make_sensor
from envs.track import PumaTrackEnv
from models import puma560, riacs

FK_TOL = 1e-9  # m: MuJoCo's sensed site against the analytic kinematics
FD_STEP = 1e-6  # rad, central differences ...
FD_TOL = 1e-7  # m/rad ... agree with the Jacobian to this
MEAN_PIXEL_TOL, MAX_PIXEL_TOL = 0.5, 1.5  # px: rendered vs projected (tests/test_stereo.py)
SETTINGS = [("riacs", 3), ("puma560", 3), ("puma560", 6)]


def _analytic_point(robot: str, q: np.ndarray) -> np.ndarray:
    """World position (m) of the sensed point from ``models``' kinematics."""
    if robot == "riacs":
        return np.array(riacs.robot3df(riacs.LINK1, riacs.LINK2, *q))
    theta = puma560.HOME.copy()
    theta[: len(q)] = q
    frame = 4 if len(q) == 3 else 6  # wrist centre = origin of frame 4, tcp = frame 6
    return puma560.frames(theta)[frame, :3, 3] + puma560.BASE_POS


def _poses(env: ArmScene, n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(
        env.joint_lower, env.joint_upper, (n, len(env.joint_lower))
    )


@pytest.mark.parametrize(("robot", "joints"), SETTINGS)
def test_set_joints_puts_the_sensed_point_where_the_analytic_kinematics_say(robot, joints):
    env = ReachEnv(robot=robot, joints=joints, sensing="project", control="servo")
    assert isinstance(env, ArmScene)
    for q in _poses(env, 20, seed=1):
        env.set_joints(q)
        np.testing.assert_allclose(env.data.qpos[env.qpos_ids], q, rtol=0, atol=0)
        np.testing.assert_allclose(env.sensed_point(), _analytic_point(robot, q), atol=FK_TOL)
    env.close()


def test_the_track_env_is_an_arm_scene_of_the_puma_tool_point():
    env = PumaTrackEnv()
    assert isinstance(env, ArmScene)
    for q in _poses(env, 10, seed=2):
        env.set_joints(q)
        np.testing.assert_allclose(env.sensed_point(), _analytic_point("puma560", q), atol=FK_TOL)
    assert env.marker_radius == pytest.approx(float(env.model.geom("marker_tcp").size[0]))
    env.close()


@pytest.mark.parametrize(("robot", "joints"), SETTINGS)
def test_sensed_point_jacobian_matches_central_differences(robot, joints):
    env = ReachEnv(robot=robot, joints=joints, sensing="project", control="kinematic")
    data = mujoco.MjData(env.model)  # a second data: the env's own must not change
    before = env.data.qpos.copy()
    for q in _poses(env, 5, seed=3):
        env.set_joints(q, data)
        jac = env.sensed_point_jacobian(data)  # (3, J)
        numeric = np.zeros_like(jac)
        for j in range(len(q)):
            step = np.zeros_like(q)
            step[j] = FD_STEP
            env.set_joints(q + step, data)
            plus = env.sensed_point(data)
            env.set_joints(q - step, data)
            numeric[:, j] = (plus - env.sensed_point(data)) / (2 * FD_STEP)
        np.testing.assert_allclose(jac, numeric, atol=FD_TOL)
    np.testing.assert_array_equal(env.data.qpos, before)
    env.close()


@pytest.mark.parametrize("robot", ["riacs", "puma560"])
def test_marker_and_target_radius_are_the_scene_geoms(robot):
    env = ReachEnv(robot=robot, sensing="project", control="kinematic")
    marker = "marker_tcp" if robot == "riacs" else "marker_wrist"
    assert env.marker_radius == float(env.model.geom(marker).size[0])
    assert env.target_radius == float(env.model.geom("target").size[0])
    env.close()


@pytest.mark.parametrize(
    ("sensing", "kind"),
    [("project", ProjectSensor), ("render", RenderSensor), ("foveated", FoveatedSensor)],
)
def test_each_sensing_mode_gets_its_sensor_once(sensing, kind):
    env = ReachEnv(sensing=sensing, control="kinematic")
    assert type(env.sensor) is kind
    if sensing == "foveated":  # the env's fovea is the sensor's: its fallbacks are counted
        assert env.sensor.fovea is env.fovea
    with pytest.raises(ValueError, match="valid: render, project, foveated"):
        make_sensor("stereo", env)
    env.close()


@pytest.mark.parametrize("robot", ["riacs", "puma560"])
def test_project_sensor_is_the_exact_projection_inside_the_images(robot):
    env = ReachEnv(robot=robot, sensing="project", control="kinematic")
    env.reset(seed=5)
    sensor = env.sensor
    rng = np.random.default_rng(5)
    seen = 0
    for q in _poses(env, 40, seed=6):
        env.data.mocap_pos[0] = env.robot_spec.workspace.sample(rng, 1)[0]
        env.set_joints(q)
        for (pixels, visible), point in (
            (sensor.sense_target(env.data), env.data.mocap_pos[0]),
            (sensor.sense_effector(env.data, np.full(4, np.nan)), env.sensed_point()),
        ):
            exact, depth = env.stereo.project_with_depth(point[None])
            u, v = exact[0, ::2], exact[0, 1::2]
            inside = (depth[0] > 0) & (u >= 0) & (u <= env.image_width - 1)
            inside &= (v >= 0) & (v <= env.image_height - 1)
            np.testing.assert_array_equal(visible, inside)
            np.testing.assert_allclose(pixels[np.repeat(inside, 2)], exact[0][np.repeat(inside, 2)],
                                       rtol=0, atol=1e-9)  # fmt: skip
            assert np.isnan(pixels[np.repeat(~inside, 2)]).all()
            seen += int(inside.all())
    assert seen > 40  # most targets and markers are in view
    env.close()


@pytest.mark.parametrize("mode", ["render", "foveated"])
def test_rendering_sensors_agree_with_the_projection(mode):
    env = ReachEnv(robot="riacs", sensing=mode, control="kinematic")
    env.reset(seed=7)
    exact = make_sensor("project", env)
    errors = []
    for q in _poses(env, 12, seed=8):
        env.set_joints(q)
        want, want_seen = exact.sense_effector(env.data, np.full(4, np.nan))
        if not want_seen.all():
            continue
        expected = want + np.random.default_rng(9).normal(0.0, 2.0, 4)  # a reach's prediction
        pixels, visible = env.sensor.sense_effector(env.data, expected)
        if visible.all():
            errors.extend(np.hypot(*(pixels - want).reshape(2, 2).T))
    assert len(errors) >= 10
    assert np.mean(errors) < MEAN_PIXEL_TOL and np.max(errors) < MAX_PIXEL_TOL
    env.close()


def test_an_env_with_its_sensor_survives_pickling():
    env = ReachEnv(robot="riacs", sensing="render", control="kinematic")
    env.reset(seed=10)
    copy = pickle.loads(pickle.dumps(env))
    command = (env.joint_lower + env.joint_upper) / 2
    obs, *_ = env.step(command)
    obs_copy, *_ = copy.step(command)
    for key in obs:
        np.testing.assert_array_equal(obs[key], obs_copy[key])
    assert copy.sensor.stereo is copy.stereo  # the copy senses through its own rig
    env.close()
    copy.close()


@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaReach-v0", "PumaGrasp-v0"])
def test_restore_start_is_mujocos_keyframe_reset(env_id):
    """After servo moves, ``restore_start`` leaves what ``mj_resetDataKeyframe`` leaves (the
    reference): the same full state, the same positions after a forward pass, and the same
    trajectory for 300 physics steps under one command."""
    import gymnasium as gym

    env = gym.make(env_id, sensing="project", control="servo").unwrapped
    env.reset(seed=4)
    rng = np.random.default_rng(4)
    for _ in range(2):
        env.step(rng.uniform(env.action_space.low, env.action_space.high))
    model, restored = env.model, env.data
    reference = mujoco.MjData(model)
    mujoco.mj_copyData(reference, model, restored)  # the same stale derived quantities
    env.restore_start()
    mujoco.mj_resetDataKeyframe(model, reference, model.key(env.markers.start_key).id)
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    states = []
    for data in (restored, reference):
        state = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, state, spec)
        states.append(state)
    np.testing.assert_array_equal(states[0], states[1])
    command = rng.uniform(model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1])
    for data in (restored, reference):
        mujoco.mj_forward(model, data)
        data.ctrl[:] = command
        for _ in range(300):
            mujoco.mj_step(model, data)
    assert restored.time == reference.time > 0
    np.testing.assert_array_equal(restored.qpos, reference.qpos)
    np.testing.assert_array_equal(restored.qvel, reference.qvel)
    np.testing.assert_array_equal(restored.geom_xpos, reference.geom_xpos)
    env.close()
