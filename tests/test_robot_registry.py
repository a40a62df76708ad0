"""The robot registry: a throwaway robot added through exactly the steps of docs/layout.md
("Adding a robot") is read by the env and its registration, the exact controllers, the figures,
the perturbations, the sweeps, the benchmark, the accuracy analysis and the demo; every robot's
kinematics agree with its MuJoCo model; a bad entry is refused with a clear error."""

from __future__ import annotations

import json
import re
import sys
import textwrap
from pathlib import Path

import cv2
import gymnasium as gym
import mujoco
import numpy as np
import pytest

import envs
import models
from envs.cli import bench_ik, demo, kinematic_accuracy
from envs.harness import plots
from envs.perturb import Perturbation
from envs.reach import ReachEnv
from envs.robots import (
    ROBOTS,
    RobotSpec,
    RobotSpecError,
    check_registry,
    grasp_env_ids,
    reach_env_ids,
    robot_of_env,
    sweep_names,
)
from envs.studies.sweep_grid import parse_value, robot_word
from learners.baselines.analytic_ik import AnalyticIK
from learners.baselines.jacobian_ik import JacobianIK
from models.analyses import nemecek_accuracy as acc
from models.arms import arm_kinematics
from models.robot_model import RobotModel, robot_model

ROOT = Path(__file__).resolve().parents[1]
NAME, ENV_ID, SHORT, TITLE = "planar2", "Planar2Reach-v0", "planar", "Planar 2-link arm"
L1, L2 = 0.3, 0.25  # m, the throwaway arm's links
TOOL_TOL = 1e-9  # m: MuJoCo's site against the written-out forward kinematics

#: Step 1 of "Adding a robot": the robot alone (joints joint1..jointN, position actuators of the
#: same names, the sensed site with a green marker in group 4, keyframes home and ready).
ROBOT_XML = f"""
<mujoco model="{NAME}">
  <compiler angle="radian" autolimits="true"/>
  <option integrator="implicitfast" timestep="0.002"/>
  <default>
    <default class="arm">
      <joint axis="0 0 1" armature="0.01" damping="0.2"/>
      <position inheritrange="1" kp="40" kv="2"/>
      <geom group="2" contype="0" conaffinity="0" type="capsule" size="0.012"
        rgba="0.8 0.8 0.8 1"/>
    </default>
  </default>
  <worldbody>
    <body name="stand" childclass="arm">
      <site name="base" size="0.01" group="5"/>
      <body name="link1">
        <inertial pos="{L1 / 2} 0 0" mass="0.5" diaginertia="0.001 0.004 0.004"/>
        <joint name="joint1" range="-1.7 1.0"/>
        <geom fromto="0 0 0 {L1} 0 0"/>
        <body name="link2" pos="{L1} 0 0">
          <inertial pos="{L2 / 2} 0 0" mass="0.3" diaginertia="0.0005 0.002 0.002"/>
          <joint name="joint2" range="0.2 2.4"/>
          <geom fromto="0 0 0 {L2 - 0.03} 0 0"/>
          <site name="tcp" pos="{L2} 0 0" size="0.005" group="5"/>
          <geom name="marker_tcp" type="sphere" size="0.02" pos="{L2} 0 0" group="4"
            rgba="0.1 0.9 0.1 1"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position class="arm" name="joint1" joint="joint1"/>
    <position class="arm" name="joint2" joint="joint2"/>
  </actuator>
  <keyframe>
    <key name="home" qpos="-0.6 1.3" ctrl="-0.6 1.3"/>
    <key name="ready" qpos="-0.6 1.3" ctrl="-0.6 1.3"/>
  </keyframe>
</mujoco>
"""

#: Step 1: the scene (floor, light, cameras cam_left, cam_right, overview, the mocap target).
SCENE_XML = f"""
<mujoco model="{NAME} scene">
  <include file="{NAME}.xml"/>
  <worldbody>
    <light name="key" pos="0.35 0 3" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" pos="0 0 -0.1" size="2 2 0.05" rgba="0.5 0.55 0.6 1"
      contype="0" conaffinity="0"/>
    <camera name="cam_left" pos="0.45 0 1" fovy="50"/>
    <camera name="cam_right" pos="0.25 0 1" fovy="50"/>
    <camera name="overview" pos="0.35 -1.2 0.8" xyaxes="1 0 0 0 0.55 0.83" fovy="45"/>
    <body name="target" mocap="true" pos="0.35 0 0">
      <geom name="target" type="sphere" size="0.02" group="1" contype="0" conaffinity="0"
        rgba="0.9 0.1 0.1 1"/>
    </body>
  </worldbody>
</mujoco>
"""

#: Step 2: the package with the robot's kinematics and its RobotModel.
INIT_PY = f'''
"""A throwaway planar arm: two joints about z, links {L1} and {L2} m, in the plane z = 0."""

import numpy as np

from models.arms import ArmKinematics
from models.chain import Chain, Element, RobotChain
from models.robot_model import RobotModel
from models.workspace import BoxWorkspace

L1, L2 = {L1}, {L2}
LOWER, UPPER = np.array([-1.7, 0.2]), np.array([1.0, 2.4])
HOME = np.array([-0.6, 1.3])
WORKSPACE = BoxWorkspace(np.array([0.25, -0.15, 0.0]), np.array([0.45, 0.15, 0.0]))


def forward(theta):
    theta = np.asarray(theta, dtype=float)
    q1, q12 = theta[..., 0], theta[..., 0] + theta[..., 1]
    x = L1 * np.cos(q1) + L2 * np.cos(q12)
    y = L1 * np.sin(q1) + L2 * np.sin(q12)
    return np.stack([x, y, np.zeros_like(x)], axis=-1)


def jacobian(theta):
    theta = np.asarray(theta, dtype=float)
    q1, q12 = theta[..., 0], theta[..., 0] + theta[..., 1]
    zero = np.zeros_like(q1)
    row_x = np.stack([-L1 * np.sin(q1) - L2 * np.sin(q12), -L2 * np.sin(q12)], axis=-1)
    row_y = np.stack([L1 * np.cos(q1) + L2 * np.cos(q12), L2 * np.cos(q12)], axis=-1)
    return np.stack([row_x, row_y, np.stack([zero, zero], axis=-1)], axis=-2)


def inverse(points, reference=None):
    p = np.atleast_2d(np.asarray(points, dtype=float))
    c2 = (p[:, 0] ** 2 + p[:, 1] ** 2 - L1**2 - L2**2) / (2 * L1 * L2)
    q2 = np.arccos(np.clip(c2, -1.0, 1.0))
    q1 = np.arctan2(p[:, 1], p[:, 0]) - np.arctan2(L2 * np.sin(q2), L1 + L2 * np.cos(q2))
    theta = np.stack([q1, q2], axis=-1)
    clipped = np.clip(theta, LOWER, UPPER)
    reachable = (np.abs(c2) <= 1) & (p[:, 2] == 0) & np.all(clipped == theta, axis=-1)
    return clipped, reachable


def arm(configuration="right-above"):
    return ArmKinematics("{NAME}", LOWER, UPPER, HOME, HOME, forward, jacobian, inverse)


def accuracy_chain():
    chain = Chain((Element("rz", "theta1"), Element("tx", "link1"), Element("rz", "theta2"),
                   Element("tx", "link2")))
    def parameters(theta):
        theta = np.asarray(theta, dtype=float)
        ones = np.ones(theta.shape[:-1])
        return np.stack([theta[..., 0], L1 * ones, theta[..., 1], L2 * ones], axis=-1)
    segments = (("body", "link2"), ("site", "tcp"))
    return RobotChain("{NAME}", chain, (0, 2), segments, parameters)


MODEL = RobotModel(name="{NAME}", reach=L1 + L2, workspace=WORKSPACE, arms={{2: arm}},
                   chain=accuracy_chain)
'''


def planar_spec(**changes) -> RobotSpec:
    """Step 3: the registry entry."""
    fields = {
        "model": NAME,
        "title": TITLE,
        "short": SHORT,
        "reach_env": ENV_ID,
        "sensed": {2: "tcp"},
        "markers": {2: "marker_tcp"},
        "tool_axes": {"tcp": (1.0, 0.0, 0.0)},  # along link 2
    }
    return RobotSpec(**{**fields, **changes})


def write_robot(root: Path) -> Path:
    """Step 1 and 2 in a folder of its own: ``root/<NAME>/``."""
    folder = root / NAME
    folder.mkdir(parents=True)
    (folder / f"{NAME}.xml").write_text(textwrap.dedent(ROBOT_XML))
    (folder / "scene.xml").write_text(textwrap.dedent(SCENE_XML))
    (folder / "README.md").write_text("# Planar 2-link arm\n\nA test's throwaway robot.\n")
    (folder / "__init__.py").write_text(textwrap.dedent(INIT_PY))
    return folder


@pytest.fixture
def planar(tmp_path, monkeypatch):
    """The throwaway robot, added as docs/layout.md says: its folder (here in a folder of the
    models package's search path instead of models/ itself, so the source tree stays as it is),
    its registry entry, its env registered; all undone after the test."""
    write_robot(tmp_path / "robots")
    monkeypatch.setattr(models, "__path__", [*models.__path__, str(tmp_path / "robots")])
    spec = planar_spec()
    monkeypatch.setitem(ROBOTS, NAME, spec)
    envs.register_robot(NAME)
    yield spec
    gym.registry.pop(ENV_ID, None)
    for module in [
        m for m in sys.modules if m == f"models.{NAME}" or m.startswith(f"models.{NAME}.")
    ]:
        del sys.modules[module]
    if hasattr(models, NAME):
        delattr(models, NAME)


def test_the_layout_doc_lists_the_steps_this_test_takes():
    """docs/layout.md names every file and entry this test writes (a step added there or here
    must be added to both)."""
    text = (ROOT / "docs" / "layout.md").read_text()
    section = text[text.index("## Adding a robot") :]
    for needle in ("<robot>.xml", "scene.xml", "README.md", "__init__.py", "MODEL",
                   "RobotModel", "RobotSpec", "envs/robots.py", "register_robot",
                   "tool_axes", "tests/test_robot_registry.py"):  # fmt: skip
        assert needle in section, needle


def test_the_throwaway_robot_is_a_model_with_kinematics(planar):
    assert NAME in models.available_models()
    assert models.model_dir(NAME).parent.name == "robots"
    model = robot_model(NAME)
    assert isinstance(model, RobotModel) and planar.kinematics is model
    assert arm_kinematics(NAME, 2).name == NAME
    with pytest.raises(ValueError, match="valid for planar2: 2 joints"):
        arm_kinematics(NAME, 3)
    check_registry(ROBOTS)
    assert reach_env_ids()[-1] == ENV_ID and ENV_ID not in grasp_env_ids()
    assert robot_of_env(ENV_ID) == NAME


def test_the_env_is_registered_and_moves_the_arm_its_kinematics_say(planar):
    env = gym.make(ENV_ID, sensing="project", control="kinematic")
    base = env.unwrapped
    assert base.robot == NAME and base.joints == 2 and base.robot_spec is planar
    obs, info = env.reset(seed=0)
    target = info["target_pos"]
    assert planar.workspace.contains(target[None])[0]
    arm = arm_kinematics(NAME, 2)
    ik = AnalyticIK.for_robot(base.nominal_stereo.triangulate, NAME, 2)
    obs, _, _, _, info = env.step(ik.act(obs["desired_goal"]))
    assert info["distance"] < 1e-6, info["distance"]  # the exact IK through the cameras
    assert np.allclose(info["effector_pos"], arm.forward(obs["observation"][:2]), atol=TOOL_TOL)
    jac = JacobianIK.for_robot(base.nominal_stereo.triangulate, NAME, 2)
    assert np.allclose(jac.act(obs["desired_goal"]), ik.act(obs["desired_goal"]), atol=1e-5)
    env.close()


def test_rendered_sensing_sees_the_throwaway_scene(planar):
    """The scene's cameras see the markers: rendered pixels equal the exact projection."""
    env = gym.make(ENV_ID, sensing="render", control="kinematic")
    obs, info = env.reset(seed=1)
    exact = env.unwrapped.stereo.project(info["target_pos"][None])[0]
    assert info["visible"] and np.allclose(obs["desired_goal"], exact, atol=0.5)
    env.close()


def test_the_tool_perturbation_moves_along_the_entry_s_tool_axis(planar):
    """A 4 cm longer tool: the sensed point is where a link 2 of L2 + 4 cm puts it (written out)."""
    env = gym.make(ENV_ID, sensing="project", control="kinematic")
    env.reset(seed=2)
    env.unwrapped.perturb(Perturbation(tool=0.04))
    theta = np.array([-0.4, 1.1])
    _, _, _, _, info = env.step(theta)
    q1, q12 = theta[0], theta.sum()
    longer = [
        L1 * np.cos(q1) + (L2 + 0.04) * np.cos(q12),
        L1 * np.sin(q1) + (L2 + 0.04) * np.sin(q12),
        0,
    ]
    assert np.allclose(info["effector_pos"], longer, atol=TOOL_TOL)
    env.close()


def test_figures_sweeps_and_the_demo_read_the_entry(planar):
    assert plots.subject(NAME, "project", "kinematic", "AnalyticIK").startswith(TITLE + " · ")
    assert sweep_names()[SHORT] == ENV_ID
    assert parse_value("robot", SHORT) == ENV_ID and robot_word(ENV_ID) == SHORT
    assert (ENV_ID, SHORT) in demo.runs()


def test_the_ik_benchmark_reads_the_entry(planar, capsys):
    bench_ik.main(["--robots", NAME, "--single", "5", "--batch", "50", "--repeats", "1"])
    out = capsys.readouterr().out
    assert f"{NAME}: 5 single queries, batch of 50" in out
    assert re.search(r"JacobianIK batch: converged 100\.00 %", out), out


def test_the_accuracy_analysis_reads_the_entry(planar, tmp_path, capsys):
    """The chain the package gives matches its MJCF: the linear model predicts MuJoCo's tool
    error for 0.1 % deviations (second order: far below the error itself)."""
    assert NAME in acc.chain_robots()
    kinematic_accuracy.main(["--robot", NAME, "--levels", "0.001", "--out", str(tmp_path)])
    result = json.loads((tmp_path / "accuracy.json").read_text())
    check = result["checks"][0]
    actual = np.linalg.norm(check["all_actual_m"])
    assert actual > 1e-5 and check["all_miss_m"] < 1e-2 * actual
    assert result["theta_rad"] == pytest.approx([-0.6, 1.3])  # the keyframe home


def test_every_model_folder_has_one_registry_entry():
    """A folder without an entry (or an entry without a folder) is a robot added half-way."""
    assert set(models.available_models()) == set(ROBOTS)
    for name, spec in ROBOTS.items():
        assert gym.spec(spec.reach_env).kwargs["robot"] == name
        assert robot_of_env(spec.reach_env) == name
        if spec.grasp_env is not None:
            assert gym.spec(spec.grasp_env).entry_point == "envs.grasp:GraspEnv"
            assert robot_of_env(spec.grasp_env) == name
    with pytest.raises(
        ValueError,
        match="registered: RiacsReach-v0, PumaReach-v0, Ur5eReach-v0, PandaReach-v0, PumaGrasp-v0",
    ):
        robot_of_env("PumaTrack-v0")


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_every_entry_s_kinematics_equal_its_mujoco_sites(name):
    """For every registered robot and joint count: forward kinematics = the sensed site in
    MuJoCo, the Jacobian = central differences, inverse(forward) = the joints."""
    spec = ROBOTS[name]
    model = models.load_model(name)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    for joints, site in spec.sensed.items():
        arm = arm_kinematics(name, joints)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        for _ in range(20):
            theta = rng.uniform(arm.lower, arm.upper)
            data.qpos[:joints] = theta
            mujoco.mj_kinematics(model, data)
            assert np.allclose(arm.forward(theta), data.site(site).xpos, atol=TOOL_TOL)
            h = 1e-6
            numeric = np.stack(
                [(arm.forward(theta + h * e) - arm.forward(theta - h * e)) / (2 * h)
                 for e in np.eye(joints)], axis=-1)  # fmt: skip
            assert np.allclose(arm.jacobian(theta), numeric, atol=1e-6)
        points = spec.workspace.sample(rng, 50)
        theta, reachable = arm.inverse(points, None)
        assert reachable.mean() > 0.99
        assert np.allclose(arm.forward(theta[reachable]), points[reachable], atol=1e-9)


def test_the_registry_refuses_bad_entries(planar):
    with pytest.raises(RobotSpecError, match="no tool axis for sensed site"):
        planar_spec(tool_axes={})
    with pytest.raises(RobotSpecError, match="unit vector"):
        planar_spec(tool_axes={"tcp": (2.0, 0.0, 0.0)})
    with pytest.raises(RobotSpecError, match="same joint counts"):
        planar_spec(markers={3: "marker_tcp"})
    with pytest.raises(models.UnknownModelError, match="no robot model named 'kuka'"):
        planar_spec(model="kuka")
    clash = {**ROBOTS, NAME: planar_spec(short="puma")}
    with pytest.raises(RobotSpecError, match="both use the sweep word 'puma'"):
        check_registry(clash)
    with pytest.raises(RobotSpecError, match="has no kinematics"):
        check_registry({**ROBOTS, NAME: planar_spec(sensed={3: "tcp"}, markers={3: "marker_tcp"})})
    with pytest.raises(RobotSpecError, match=r"ROBOTS\['other'\]"):
        check_registry({"other": planar})


def test_a_folder_without_model_says_what_to_add(tmp_path, monkeypatch):
    folder = write_robot(tmp_path / "robots")
    (folder / "__init__.py").write_text('"""No MODEL here."""\n')
    monkeypatch.setattr(models, "__path__", [*models.__path__, str(tmp_path / "robots")])
    try:
        with pytest.raises(models.UnknownModelError, match="must define MODEL = RobotModel"):
            robot_model(NAME)
    finally:
        sys.modules.pop(f"models.{NAME}", None)
        if hasattr(models, NAME):
            delattr(models, NAME)


def test_the_demo_films_every_registered_arm_at_its_own_joint_count(tmp_path):
    """The demo's scene images of every robot in the registry (a 7-joint-only arm included):
    both sensing images show the red target where the cameras' projection puts it."""
    paths = demo.scene_images(tmp_path)
    assert len(paths) == 3 * len(ROBOTS)
    for name, spec in ROBOTS.items():
        env = ReachEnv(robot=name, joints=spec.joint_options[0], sensing="project")
        _, info = env.reset(seed=demo.SCENE_SEED)
        target = env.stereo.project(info["target_pos"][None])[0]  # (4,) sensing pixels
        scale = demo.SCENE_IMAGE_SIZE[0] / env.image_width
        env.close()
        for k, camera in enumerate(("cam_left", "cam_right")):
            image = cv2.imread(str(tmp_path / f"{name}_{camera}.png"))[..., ::-1].astype(int)
            red = (image[..., 0] > 150) & (image[..., 1] < 80) & (image[..., 2] < 80)
            rows, cols = np.nonzero(red)
            assert len(rows), f"{name} {camera}: no red target pixel"
            expected = (target[2 * k : 2 * k + 2] + 0.5) * scale  # pixel centres at scale
            found = np.array([cols.mean(), rows.mean()])
            assert np.linalg.norm(found - expected) < 0.02 * demo.SCENE_IMAGE_SIZE[0], name
