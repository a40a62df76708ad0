"""Arms from a DH table (models/dh_arm.py, models/dh_mjcf.py, visuomotor-make-arm) and a user's
own MJCF (ArmReach-v0): the generated models against independent DH forward kinematics and the
tables' published figures, the automatic cameras, the one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
import pytest
import tomllib
from gymnasium.utils.env_checker import check_env

import envs
import models
from envs.arm_reach import UserModelError
from envs.harness.evaluation import evaluate
from envs.harness.trials import learn_from, run_trial
from envs.robots import ROBOTS, RobotSpec, check_registry
from learners.baselines.analytic_ik import AnalyticIK
from learners.som.config import SOMConfig
from learners.som.controller import VisuomotorSOM
from models import dh_arm, dh_mjcf
from models.arms import arm_kinematics
from models.dh import DHTable, forward_frames

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-9  # m: MuJoCo's site against the DH chain
USER_JOINTS = ["shoulder_pan", "shoulder_lift", "elbow"]
#: A small arm written by the test: three hinges, a motor on one, a keyframe not named home.
USER_XML = """
<mujoco model="user_arm">
  <compiler angle="radian"/>
  <worldbody>
    <body name="base_link" pos="0 0 0.5">
      <joint name="shoulder_pan" axis="0 0 1" range="-1.5 1.5" limited="true"/>
      <geom type="capsule" fromto="0 0 0 0 0 0.1" size="0.03"/>
      <body name="upper" pos="0 0 0.1">
        <joint name="shoulder_lift" axis="0 1 0" range="-1.2 1.2" limited="true"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.025"/>
        <body name="fore" pos="0.3 0 0">
          <joint name="elbow" axis="0 1 0" range="0.2 2.4" limited="true"/>
          <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02"/>
          <site name="grip" pos="0.25 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator><motor name="m1" joint="shoulder_pan"/></actuator>
  <keyframe><key name="start" qpos="0.2 0.1 3.0" ctrl="0"/></keyframe>
</mujoco>
"""


def table(name: str) -> dh_arm.DHArm:
    return dh_arm.read_table(ROOT / "models" / name / "dh.toml")


def mujoco_tcp(name: str, theta: np.ndarray) -> np.ndarray:
    model = models.load_model(name)
    data = mujoco.MjData(model)
    data.qpos[:] = theta
    mujoco.mj_kinematics(model, data)
    return data.site("tcp").xpos.copy()


def craig(theta: np.ndarray, arm: dh_arm.DHArm) -> np.ndarray:
    """Craig's modified DH written out: T_i = Rx(α_(i-1)) Tx(a_(i-1)) Rz(θ_i) Tz(d_i)."""

    def link(alpha: float, a: float, theta: float, d: float) -> np.ndarray:
        ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
        return np.array([[ct, -st, 0, a], [st * ca, ct * ca, -sa, -sa * d],
                         [st * sa, ct * sa, ca, ca * d], [0, 0, 0, 1]])  # fmt: skip

    T = np.eye(4)
    T[2, 3] = arm.base_height
    for i in range(arm.n):
        T = T @ link(arm.alpha[i], arm.a[i], theta[i] + arm.offset[i], arm.d[i])
    a, d, alpha, offset = arm.tool
    return (T @ link(alpha, a, offset, d))[:3, 3]


def test_the_ur5e_is_universal_robots_table_in_mujoco():
    """MuJoCo's tcp = the standard DH chain of models/dh.py (the PUMA's) at random joints, and
    at zero the UR5e's published stretched pose: x = a2 + a3, y = -(d4 + d6), z = d1 - d5."""
    arm = table("ur5e")
    dh = DHTable(arm.alpha, arm.a, arm.d, arm.lower, arm.upper)
    rng = np.random.default_rng(0)
    for theta in rng.uniform(arm.lower, arm.upper, size=(20, 6)):
        expected = forward_frames(dh, theta)[6, :3, 3] + [0, 0, arm.base_height]
        assert np.allclose(mujoco_tcp("ur5e", theta), expected, atol=TOL)
    zero = mujoco_tcp("ur5e", np.zeros(6)) - [0, 0, arm.base_height]
    assert np.allclose(zero, [-0.425 - 0.3922, -0.1333 - 0.0996, 0.1625 - 0.0997], atol=TOL)


def test_the_panda_is_franka_s_modified_table_in_mujoco():
    """MuJoCo's tcp = Craig's chain written out here, and at zero Franka's flange at
    (a7, 0, d1 + d3 + d5 - d_flange) = (0.088, 0, 0.926) m above the base."""
    arm = table("panda")
    rng = np.random.default_rng(1)
    for theta in rng.uniform(arm.lower, arm.upper, size=(20, 7)):
        assert np.allclose(mujoco_tcp("panda", theta), craig(theta, arm), atol=TOL)
    zero = np.clip(np.zeros(7), arm.lower, arm.upper)
    data_zero = craig(np.zeros(7), arm) - [0, 0, arm.base_height]
    assert np.allclose(data_zero, [0.088, 0, 0.926], atol=TOL)
    model = models.load_model("panda")
    data = mujoco.MjData(model)
    data.qpos[:] = zero
    mujoco.mj_kinematics(model, data)
    assert np.allclose(data.site("tcp").xpos, craig(zero, arm), atol=TOL)


@pytest.mark.parametrize("name", ["ur5e", "panda"])
def test_the_shipped_folder_is_what_make_arm_writes_from_its_table(name, tmp_path):
    out = tmp_path / name
    subprocess.run([sys.executable, str(ROOT / "scripts" / "make_arm.py"),
                    str(ROOT / "models" / name / "dh.toml"), "--out", str(out)],
                   check=True, capture_output=True)  # fmt: skip
    for file in (f"{name}.xml", "scene.xml", "README.md", "__init__.py", "dh.toml"):
        assert (out / file).read_text() == (ROOT / "models" / name / file).read_text(), file


@pytest.mark.parametrize("robot, joints", [("ur5e", 3), ("ur5e", 6), ("panda", 7)])
def test_the_automatic_cameras_see_the_marker_at_reached_targets(robot, joints):
    """Rendered sensing sees the green marker in both images with the arm at the exact IK of
    random targets (from its ready pose) in at least 95 % of the trials, and the targets too."""
    env = gym.make(f"{robot.capitalize()}Reach-v0", joints=joints, sensing="render",
                   control="kinematic")  # fmt: skip
    arm = arm_kinematics(robot, joints)
    seen = []
    for seed in range(40):
        _, info = env.reset(seed=seed)
        theta, reachable = arm.inverse(info["target_pos"][None], None)
        assert reachable[0]
        _, _, _, _, moved = env.step(theta[0])
        assert moved["distance"] < 1e-6
        seen.append(moved["visible_effector"].all() and info["visible_target"].all())
    env.close()
    assert np.mean(seen) >= 0.95, np.mean(seen)


def test_the_cameras_frame_every_sampled_point_with_the_margin():
    """An independent pinhole check of place_cameras: every sampled tcp projects inside the
    image shrunk by the margin (MuJoCo's camera frame: x right, y up, looking along -z)."""
    arm = table("ur5e")
    points = dh_mjcf.camera_points(arm)
    model = models.load_model("ur5e")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for name in ("cam_left", "cam_right"):
        R, pos = data.cam(name).xmat.reshape(3, 3), data.cam(name).xpos
        local = (points - pos) @ R  # (N, 3) in the camera frame
        assert np.all(local[:, 2] < 0)
        f = 1 / np.tan(np.radians(model.cam(name).fovy[0]) / 2)
        u, v = f * local[:, 0] / -local[:, 2] / (4 / 3), f * local[:, 1] / -local[:, 2]
        assert np.max(np.maximum(np.abs(u), np.abs(v))) <= 1 - dh_mjcf.CAMERA_MARGIN + 1e-7


BAD_TABLES = {
    'name = "x"\n': "convention must be one of",
    'name = "x"\nconvention = "standard"\nangle_unit = "deg"\n': "give the table as [[joint]]",
    'name = "x"\nconvention = "craig"\n': "convention must be one of",
    'name = "x"\nconvention = "modified"\nangle_unit = "rad"\n[[joint]]\na = 0\n': "no d",
}


@pytest.mark.parametrize("text, message", BAD_TABLES.items())
def test_a_bad_table_is_one_line_naming_what_is_wrong(text, message, tmp_path):
    path = tmp_path / "arm.toml"
    path.write_text(text)
    with pytest.raises(dh_arm.DHTableError, match=message.replace("[", r"\[")):
        dh_arm.read_table(path)
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "make_arm.py"), str(path)],
                         capture_output=True, text=True, cwd=tmp_path)  # fmt: skip
    assert run.returncode == 2 and len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert message in run.stderr and not any(tmp_path.glob("*/"))


def test_a_json_table_is_the_same_arm_as_its_toml(tmp_path):
    path = tmp_path / "ur5e.json"
    path.write_text(json.dumps(tomllib.loads((ROOT / "models" / "ur5e" / "dh.toml").read_text())))
    toml, as_json = table("ur5e"), dh_arm.read_table(path)
    for name in ("a", "d", "alpha", "offset", "lower", "upper", "home", "radius", "tool"):
        assert np.array_equal(getattr(toml, name), getattr(as_json, name)), name
    assert dh_mjcf.robot_xml(as_json) == dh_mjcf.robot_xml(toml)


def test_a_range_with_lower_above_upper_is_refused(tmp_path):
    text = (
        (ROOT / "models" / "ur5e" / "dh.toml")
        .read_text()
        .replace("lower = -180.0", "lower = 200.0")
    )
    path = tmp_path / "arm.toml"
    path.write_text(text)
    with pytest.raises(dh_arm.DHTableError, match="joint 3 has lower ≥ upper"):
        dh_arm.read_table(path)


# -- a user's own MJCF ----------------------------------------------------------------------------


@pytest.fixture
def user_xml(tmp_path) -> Path:
    path = tmp_path / "user_arm.xml"
    path.write_text(USER_XML)
    return path


def make_user(robot, **kwargs):
    return gym.make("ArmReach-v0", robot=robot, joints=USER_JOINTS, effector_site="grip",
                    sensing="project", control="kinematic", **kwargs)  # fmt: skip


def test_a_user_mjcf_passes_gymnasium_s_env_checker(user_xml):
    with warnings.catch_warnings():
        warnings.filterwarnings("error")
        warnings.filterwarnings("ignore", ".*symmetric and normalized")
        check_env(make_user(user_xml).unwrapped, skip_render_check=True)


def test_a_user_mjcf_reads_ranges_and_keyframe_and_reaches_through_its_cameras(user_xml):
    env = make_user(str(user_xml))
    base = env.unwrapped
    assert np.allclose(base.joint_lower, [-1.5, -1.2, 0.2])
    assert np.allclose(base.joint_upper, [1.5, 1.2, 2.4])
    obs, info = env.reset(seed=3)
    assert np.allclose(obs["observation"], [0.2, 0.1, 2.4])  # keyframe "start", clipped
    # the site written out: pan about z, lift and elbow about y (x forward, z up)
    q1, q2, q3 = obs["observation"]
    r = 0.3 * np.cos(q2) + 0.25 * np.cos(q2 + q3)
    z = 0.6 - 0.3 * np.sin(q2) - 0.25 * np.sin(q2 + q3)
    assert np.allclose(info["effector_pos"], [r * np.cos(q1), r * np.sin(q1), z], atol=TOL)
    arm = base.robot_spec.kinematics.arm(3)
    theta, reachable = arm.inverse(info["target_pos"][None], None)
    assert reachable[0]
    _, _, _, _, info = env.step(theta[0])
    assert info["distance"] < 1e-6 and info["visible"]
    env.close()


def test_a_user_mjspec_is_used_as_a_copy(user_xml):
    spec = mujoco.MjSpec.from_file(str(user_xml))
    env = make_user(spec)
    env.reset(seed=0)
    assert [j.name for j in spec.joints] == USER_JOINTS and len(spec.cameras) == 0
    assert {"cam_left", "cam_right", "overview"} <= {
        env.unwrapped.model.cam(i).name for i in range(env.unwrapped.model.ncam)
    }
    env.close()


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"joints": ["shoulder_pan", "wrist"]}, r"no joint\(s\) \['wrist'\]; its joints: "),
        ({"effector_site": "hand"}, "no site 'hand'; its sites: grip"),
        ({"robot": "missing.xml"}, "no MJCF file missing.xml"),
    ],
)
def test_a_model_without_the_named_parts_is_one_line(user_xml, kwargs, message):
    arguments = {"robot": user_xml, "joints": USER_JOINTS, "effector_site": "grip", **kwargs}
    with pytest.raises(UserModelError, match=message) as caught:
        gym.make("ArmReach-v0", **arguments)
    assert "\n" not in str(caught.value)


def test_a_map_learns_to_reach_with_a_user_mjcf(user_xml):
    """The map trains on the test's MJCF through its cameras (project, kinematic): after 1500
    trials its error after two fine moves is a fifth of the untrained map's at most (its home,
    the keyframe clipped into range, folds the arm; the map starts at ``ready``)."""
    env = make_user(user_xml)
    base = env.unwrapped
    env.reset(seed=0)
    seen = np.array([base.sensed_target() for _ in range(50) if env.reset() is not None])
    ready = base.model.key("ready").qpos[base.qpos_ids]
    som = VisuomotorSOM(base.joint_lower, base.joint_upper, SOMConfig.of(t_max=1500),
                        rng=np.random.default_rng(0), input_low=seen.min(axis=0),
                        input_high=seen.max(axis=0), theta_init=ready)  # fmt: skip
    env.reset(seed=1)
    before = evaluate(env, som, 100).distances[:, -1].mean()
    env.reset(seed=2)
    for _ in range(1500):
        learn_from(som, run_trial(env, som, 2, explore=True))
    env.reset(seed=1)
    after = evaluate(env, som, 100).distances[:, -1].mean()
    assert after < 0.2 * before, (before, after)
    env.close()


#: A three-joint elbow arm (standard DH) that a user might write: the registry entry below is
#: the only edit its folder needs.
ELBOW_TOML = """
name = "elbow3"
title = "Elbow arm"
convention = "standard"
angle_unit = "deg"
source = "A test's arm."
base_height = 0.5
controlled = [3]

[workspace]
lower = [0.25, -0.15, 0.45]
upper = [0.45, 0.15, 0.65]

[[joint]]
a = 0.0
d = 0.2
alpha = 90.0
lower = -170.0
upper = 170.0
home = 0.0
radius = 0.03

[[joint]]
a = 0.3
d = 0.0
alpha = 0.0
lower = -10.0
upper = 170.0
home = 45.0
radius = 0.025

[[joint]]
a = 0.25
d = 0.0
alpha = 0.0
lower = -160.0
upper = 0.0
home = -90.0
radius = 0.02
"""


@pytest.fixture
def elbow_arm(tmp_path, monkeypatch):
    """The folder written by make_arm's function into a folder of the models package's path,
    one RobotSpec in the registry, its env registered; all undone after the test."""
    arm = dh_arm.parse_table(tomllib.loads(ELBOW_TOML))
    dh_mjcf.write_folder(arm, tmp_path / "robots" / "elbow3", "dh.toml", ELBOW_TOML)
    monkeypatch.setattr(models, "__path__", [*models.__path__, str(tmp_path / "robots")])
    spec = RobotSpec(model="elbow3", title="Elbow arm", short="elbow", reach_env="ElbowReach-v0",
                     sensed={3: "tcp"}, markers={3: "marker_tcp"},
                     tool_axes={"tcp": (0.0, 0.0, 1.0)}, default_runs=False)  # fmt: skip
    monkeypatch.setitem(ROBOTS, "elbow3", spec)
    envs.register_robot("elbow3")
    yield arm
    gym.registry.pop("ElbowReach-v0", None)
    for module in [m for m in sys.modules if m.startswith("models.elbow3")]:
        del sys.modules[module]
    if hasattr(models, "elbow3"):
        delattr(models, "elbow3")


def test_a_generated_arm_needs_only_its_registry_entry(elbow_arm):
    """Its env reaches a target through the cameras with the exact IK, the tcp is the
    standard DH chain of models/dh.py, and rendered sensing sees both markers."""
    check_registry(ROBOTS)
    dh = DHTable(elbow_arm.alpha, elbow_arm.a, elbow_arm.d, elbow_arm.lower, elbow_arm.upper)
    for sensing in ("project", "render"):
        env = gym.make("ElbowReach-v0", sensing=sensing, control="kinematic")
        base = env.unwrapped
        obs, info = env.reset(seed=4)
        ik = AnalyticIK.for_robot(base.nominal_stereo.triangulate, "elbow3", 3)
        obs, _, _, _, info = env.step(ik.act(obs["desired_goal"]))
        expected = forward_frames(dh, obs["observation"])[3, :3, 3] + [0, 0, 0.5]
        assert np.allclose(info["effector_pos"], expected, atol=TOL)
        assert info["visible"]
        if sensing == "project":
            assert info["distance"] < 1e-6, info["distance"]
        env.close()
