"""Robot models: layout, stepping without warnings, kinematics, servo accuracy, workspaces.

Every expected value is written here from the sources, never taken from the code under test:
the PUMA 560 table of Brause (1989) Fig. 2b (from Fu, Gonzalez & Lee 1987) and the RIACS arm and
cameras of Jorgensen (1990), RIACS TR 90.28 (appendix: robot3df, robot3dinv, camera, camerafd,
build3dpts).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import models
from models import puma560, riacs
from models.robot_model import robot_model

DEG = math.pi / 180.0  # rad per degree
MM = 1e-3  # m per mm

# Brause (1989) Fig. 2b, "PUMA robot arm link coordinate parameters", as printed (deg, mm).
PUMA_THETA_DEG = np.array([90.0, 0.0, 90.0, 0.0, 0.0, 0.0])
PUMA_ALPHA_DEG = np.array([-90.0, 0.0, 90.0, -90.0, 90.0, 0.0])
PUMA_A_MM = np.array([0.0, 431.8, -20.32, 0.0, 0.0, 0.0])
PUMA_D_MM = np.array([0.0, 149.09, 0.0, 433.07, 0.0, 56.25])
PUMA_RANGE_DEG = np.array(
    [
        [-160.0, 160.0],
        [-225.0, 45.0],
        [-45.0, 225.0],
        [-110.0, 170.0],
        [-100.0, 100.0],
        [-266.0, 266.0],
    ]
)
PUMA_LOWER, PUMA_UPPER = PUMA_RANGE_DEG.T * DEG
#: The documented PUMA target box, relative to DH frame 0 (models/puma560/README.md), m.
PUMA_BOX_LOWER = np.array([-0.25, 0.35, -0.30])
PUMA_BOX_UPPER = np.array([0.25, 0.75, 0.30])
PUMA_BASE_HEIGHT = 0.6718  # m, world z of DH frame 0 (site base)
PUMA_REACH_MARGIN = 0.03  # m, documented clearance of the box inside the reach sphere
PUMA_AXIS_CLEARANCE = 0.2  # m, documented distance of the box from the joint-1 axis

# Jorgensen (1990), build3dpts: arm1 = .6, arm2 = .4 and the loop ranges of the three joints.
RIACS_L1, RIACS_L2 = 0.6, 0.4
RIACS_RANGE = np.array(
    [
        [0.001, math.pi / 2],
        [0.001, math.pi / 2 - math.asin(RIACS_L2 / RIACS_L1)],
        [0.001, math.pi - math.pi / 180],
    ]
)
RIACS_LOWER, RIACS_UPPER = RIACS_RANGE.T
RIACS_FOCAL, RIACS_HALF_SEPARATION = 1.0, 0.3  # build3dpts: focallength=1, separation=.3
#: The documented RIACS bounding box (models/riacs/README.md), m.
RIACS_BOX_LOWER = np.array([0.0, 0.0, -0.40])
RIACS_BOX_UPPER = np.array([1.0, 1.0, 0.75])

MJCF_ANGLE_TOL = 1e-6  # rad: the MJCF files write angles with 7 significant digits
FK_TOL = 1e-9  # m (and rad for orientations)
SIM_SECONDS = 1.0  # s of simulated time for the stepping and servo tests
SERVO_TOL = 1e-3  # rad: every joint within 1 mrad of its command
N_FK_SAMPLES = 1000
N_SERVO_POSES = 100
N_WORKSPACE_SAMPLES = 16000


# --------------------------------------------------------------------------- helpers


def _qpos_indices(model: mujoco.MjModel, n: int) -> np.ndarray:
    """qpos addresses of joint1..joint<n>."""
    return np.array([model.joint(f"joint{i + 1}").qposadr[0] for i in range(n)])


def _rot_z(theta: np.ndarray) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    T = np.zeros((*np.shape(theta), 4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 1, 0], T[..., 1, 1] = c, -s, s, c
    T[..., 2, 2] = T[..., 3, 3] = 1.0
    return T


def _rot_x(alpha: float) -> np.ndarray:
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _translate(x: float, y: float, z: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = x, y, z
    return T


def puma_frames(theta: np.ndarray) -> np.ndarray:
    """T_0i, i = 0..6, as the product of A_i = Rz(θ_i)·Tz(d_i)·Tx(a_i)·Rx(α_i); (N, 7, 4, 4)."""
    theta = np.atleast_2d(theta)
    frames = [np.broadcast_to(np.eye(4), (len(theta), 4, 4))]
    for i in range(6):
        fixed = (
            _translate(0, 0, PUMA_D_MM[i] * MM)
            @ _translate(PUMA_A_MM[i] * MM, 0, 0)
            @ _rot_x(PUMA_ALPHA_DEG[i] * DEG)
        )
        frames.append(frames[-1] @ _rot_z(theta[:, i]) @ fixed)
    return np.stack(frames, axis=1)


def fu_indicators(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fu, Gonzalez & Lee's configuration indicators (ARM, ELBOW) of joint angles (N, >=3)."""
    a2, a3, d4 = PUMA_A_MM[1] * MM, PUMA_A_MM[2] * MM, PUMA_D_MM[3] * MM
    t2, t3 = theta[:, 1], theta[:, 2]
    arm = np.sign(-d4 * np.sin(t2 + t3) - a3 * np.cos(t2 + t3) - a2 * np.cos(t2))
    elbow = arm * np.sign(d4 * np.cos(t3) - a3 * np.sin(t3))
    return arm, elbow


def robot3df_report(l1, l2, theta1, theta2, theta3):
    """The report's robot3df, transcribed line by line from the appendix."""
    d = np.sqrt(l1**2 + l2**2 - 2 * l1 * l2 * np.cos(theta3))
    tstar = theta2 - np.arccos((d**2 + l1**2 - l2**2) / (2 * d * l1))
    r = d * np.cos(tstar)
    z = d * np.sin(tstar)
    return np.stack([r * np.sin(theta1), r * np.cos(theta1), z], axis=-1)


def riacs_chain(theta: np.ndarray) -> np.ndarray:
    """The same arm as a serial chain: link 1 at elevation θ2 in the vertical plane at azimuth θ1
    (measured from +y towards +x), link 2 turned down from link 1's direction by π - θ3."""
    t1, t2, t3 = theta[:, 0], theta[:, 1], theta[:, 2]
    azimuth = np.stack([np.sin(t1), np.cos(t1)], axis=-1)  # (N, 2) unit vector in the x-y plane

    def direction(elevation: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [np.cos(elevation)[:, None] * azimuth, np.sin(elevation)[:, None]], axis=-1
        )

    return RIACS_L1 * direction(t2) + RIACS_L2 * direction(t2 + t3 - math.pi)


def riacs_reachable(points: np.ndarray) -> np.ndarray:
    """(N, 3) -> (N,) bool: the report's robot3dinv (transcribed) lands in build3dpts' ranges."""
    x, y, z = points.T
    d = np.sqrt(x**2 + y**2 + z**2)
    with np.errstate(invalid="ignore", divide="ignore"):
        theta3 = np.arccos((RIACS_L1**2 + RIACS_L2**2 - d**2) / (2 * RIACS_L1 * RIACS_L2))
        theta2 = np.arcsin(z / d) + np.arccos(
            (d**2 + RIACS_L1**2 - RIACS_L2**2) / (2 * d * RIACS_L1)
        )
        theta1 = np.arctan2(x, y)
    theta = np.stack([theta1, theta2, theta3], axis=-1)
    return np.all((theta >= RIACS_LOWER) & (theta <= RIACS_UPPER), axis=-1)


def octant_fractions(points: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Fraction of the points in each of the 8 octants of the box [lower, upper]; (8,)."""
    bits = (points >= (lower + upper) / 2).astype(int)  # (N, 3)
    index = bits @ np.array([1, 2, 4])
    return np.bincount(index, minlength=8) / len(points)


def grid(lower: np.ndarray, upper: np.ndarray, n: int) -> np.ndarray:
    """n³ cell centres of the box [lower, upper]; (n³, 3)."""
    axes = [lower[i] + (np.arange(n) + 0.5) * (upper[i] - lower[i]) / n for i in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def box_lattice(lower: np.ndarray, upper: np.ndarray, n: int) -> np.ndarray:
    """n³ points of the box including its faces, edges and corners; (n³, 3)."""
    axes = [np.linspace(lower[i], upper[i], n) for i in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def halton(n: int, dim: int) -> np.ndarray:
    """First n points (after the origin) of the Halton sequence in [0, 1)^dim; (n, dim)."""
    primes = [2, 3, 5, 7, 11, 13, 17, 19][:dim]
    out = np.zeros((n, dim))
    for j, base in enumerate(primes):
        index = np.arange(1, n + 1)
        scale = 1.0
        while np.any(index > 0):
            scale /= base
            out[:, j] += scale * (index % base)
            index //= base
    return out


# --------------------------------------------------------------------------- layout


def test_every_model_folder_has_robot_scene_and_readme():
    folders = sorted(p.parent for p in models.MODELS_DIR.glob("*/scene.xml"))
    assert {f.name for f in folders} >= {"puma560", "riacs"}
    for folder in folders:
        for name in (f"{folder.name}.xml", "README.md", "__init__.py"):
            assert (folder / name).is_file(), f"{folder} lacks {name}"
        assert robot_model(folder.name).name == folder.name  # its __init__.py defines MODEL
    assert models.available_models() == tuple(f.name for f in folders)


@pytest.mark.parametrize("name", models.available_models())
def test_robot_file_is_the_robot_alone(name):
    robot = models.load_model(name, scene=False)
    scene = models.load_model(name)
    assert robot.ncam == 0 and robot.nmocap == 0  # cameras and target belong to the scene
    assert robot.njnt == scene.njnt and robot.nu == scene.nu
    assert {scene.camera(i).name for i in range(scene.ncam)} >= {"cam_left", "cam_right"}
    assert scene.body("target").mocapid[0] >= 0


def test_missing_scene_file_is_one_clear_error():
    with pytest.raises(models.UnknownModelError, match=r"has no scene file 'scene_x\.xml'"):
        models.load_model("puma560", scene_file="scene_x.xml")


@pytest.mark.parametrize("call", [models.load_model, models.scene_path, models.robot_path])
def test_unknown_model_lists_the_available_ones(call):
    with pytest.raises(models.UnknownModelError) as info:
        call("nope")
    assert "nope" in str(info.value)
    for name in ("puma560", "riacs"):
        assert name in str(info.value)
    assert isinstance(info.value, ValueError)


# --------------------------------------------------------------------------- stepping


#: Every scene file of every robot (``scene.xml``, and the grasp task's ``scene_grasp.xml``).
SCENES = sorted((p.parent.name, p.name) for p in models.MODELS_DIR.glob("*/scene*.xml"))


@pytest.mark.parametrize(("name", "scene_file"), SCENES)
def test_scene_steps_without_warnings(name, scene_file):
    """Menagerie's model test: quasi-random controls within ctrlrange for 1 s, no warning."""
    model = models.load_model(name, scene_file=scene_file)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    lo, hi = model.actuator_ctrlrange.T
    assert np.all(model.actuator_ctrllimited) and np.all(hi > lo)
    hold_steps = round(0.05 / model.opt.timestep)  # a new control every 50 ms
    n_steps = round(SIM_SECONDS / model.opt.timestep)
    controls = lo + (hi - lo) * halton(n_steps // hold_steps + 1, model.nu)
    for step in range(n_steps):
        data.ctrl[:] = controls[step // hold_steps]
        mujoco.mj_step(model, data)
    warnings = {mujoco.mjtWarning(i).name: data.warning[i].number for i in range(len(data.warning))}
    assert all(n == 0 for n in warnings.values()), warnings
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))


# --------------------------------------------------------------------------- PUMA 560


@pytest.fixture(scope="module")
def puma():
    model = models.load_model("puma560")
    return model, mujoco.MjData(model)


def _relative_to_base(data: mujoco.MjData, site: str) -> tuple[np.ndarray, np.ndarray]:
    """Position (3,) and orientation (3, 3) of a site in the frame of site ``base``."""
    base_pos, base_mat = data.site("base").xpos, data.site("base").xmat.reshape(3, 3)
    pos = base_mat.T @ (data.site(site).xpos - base_pos)
    mat = base_mat.T @ data.site(site).xmat.reshape(3, 3)
    return pos, mat


def test_puma_sites_equal_the_dh_product(puma):
    model, data = puma
    rng = np.random.default_rng(560)
    theta = rng.uniform(PUMA_LOWER, PUMA_UPPER, size=(N_FK_SAMPLES, 6))
    expected = puma_frames(theta)  # (N, 7, 4, 4)
    qidx = _qpos_indices(model, 6)
    wrist, tcp, tcp_mat = [], [], []
    for q in theta:
        data.qpos[qidx] = q
        mujoco.mj_kinematics(model, data)
        wrist.append(_relative_to_base(data, "wrist_center")[0])
        pos, mat = _relative_to_base(data, "tcp")
        tcp.append(pos)
        tcp_mat.append(mat)
    np.testing.assert_allclose(wrist, expected[:, 4, :3, 3], atol=FK_TOL, rtol=0)
    np.testing.assert_allclose(tcp, expected[:, 6, :3, 3], atol=FK_TOL, rtol=0)
    np.testing.assert_allclose(tcp_mat, expected[:, 6, :3, :3], atol=FK_TOL, rtol=0)
    # Brause (5.6), the Python wrist-centre formula, is the same point.
    np.testing.assert_allclose(
        puma560.wrist_center(theta), expected[:, 4, :3, 3], atol=FK_TOL, rtol=0
    )
    np.testing.assert_allclose(puma560.wrist_center(theta), wrist, atol=FK_TOL, rtol=0)


def test_puma_base_site_is_frame_0(puma):
    model, data = puma
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(data.site("base").xpos, [0, 0, PUMA_BASE_HEIGHT], atol=1e-12)
    np.testing.assert_allclose(data.site("base").xmat.reshape(3, 3), np.eye(3), atol=1e-12)
    np.testing.assert_allclose(puma560.BASE_POS, [0, 0, PUMA_BASE_HEIGHT], atol=1e-12)


def test_puma_home_and_ranges_equal_the_table(puma):
    model, _ = puma
    qidx = _qpos_indices(model, 6)
    home = model.key("home")
    np.testing.assert_allclose(home.qpos[qidx], PUMA_THETA_DEG * DEG, atol=MJCF_ANGLE_TOL)
    np.testing.assert_allclose(home.ctrl, PUMA_THETA_DEG * DEG, atol=MJCF_ANGLE_TOL)
    ranges = np.array([model.joint(f"joint{i + 1}").range for i in range(6)])
    np.testing.assert_allclose(ranges, PUMA_RANGE_DEG * DEG, atol=MJCF_ANGLE_TOL)
    np.testing.assert_allclose(model.actuator_ctrlrange, PUMA_RANGE_DEG * DEG, atol=MJCF_ANGLE_TOL)
    # The Python table is the printed one.
    np.testing.assert_allclose(puma560.DH.alpha, PUMA_ALPHA_DEG * DEG, atol=1e-15)
    np.testing.assert_allclose(puma560.DH.a, PUMA_A_MM * MM, atol=1e-15)
    np.testing.assert_allclose(puma560.DH.d, PUMA_D_MM * MM, atol=1e-15)
    np.testing.assert_allclose(puma560.DH.lower, PUMA_LOWER, atol=1e-15)
    np.testing.assert_allclose(puma560.DH.upper, PUMA_UPPER, atol=1e-15)
    np.testing.assert_allclose(puma560.HOME, PUMA_THETA_DEG * DEG, atol=1e-15)


# Armstrong, Khatib & Burdick (1986) as collected by Corke & Armstrong-Hélouvry (1994), in the
# standard-DH frames i (Robotics Toolbox puma560.m): masses (kg), principal moments about the COM in
# frame i (kg m²), motor inertia Jm (kg m²), gear ratio G and motor viscous friction B (N m s/rad).
PUMA_MASS = np.array([np.nan, 17.4, 4.8, 0.82, 0.34, 0.09])  # link 1: not identifiable
PUMA_INERTIA = np.array(
    [
        [np.nan, 0.35, np.nan],  # link 1: only the moment about the joint-1 axis (y1)
        [0.13, 0.524, 0.539],
        [0.066, 0.086, 0.0125],
        [1.8e-3, 1.3e-3, 1.8e-3],
        [0.3e-3, 0.4e-3, 0.3e-3],
        [0.15e-3, 0.15e-3, 0.04e-3],
    ]
)
PUMA_JM = np.array([200e-6, 200e-6, 200e-6, 33e-6, 33e-6, 33e-6])
PUMA_GEAR = np.array([-62.6111, 107.815, -53.7063, 76.0364, 71.923, 76.686])
PUMA_B = np.array([1.48e-3, 0.817e-3, 1.38e-3, 71.2e-6, 82.6e-6, 36.7e-6])
#: Documented departures (README): link 1 gets 1 kg; link 3's roll moment 0.0125 -> 0.020, the
#: smallest value that satisfies the triangle inequality with 0.066 and 0.086.
PUMA_LINK1_MASS = 1.0
PUMA_LINK3_ROLL = 0.020
PARAM_RTOL = 5e-3  # the MJCF writes these with three significant digits


def test_puma_mass_properties_are_the_published_ones(puma):
    model, data = puma
    theta = np.random.default_rng(3).uniform(PUMA_LOWER, PUMA_UPPER)
    data.qpos[_qpos_indices(model, 6)] = theta
    mujoco.mj_kinematics(model, data)
    frames = puma_frames(theta)[0]  # (7, 4, 4)
    inertia = PUMA_INERTIA.copy()
    inertia[2, 2] = PUMA_LINK3_ROLL
    for i in range(1, 7):
        body = model.body(f"link{i}")
        axes = data.ximat[body.id].reshape(3, 3)  # principal axes in the world (= frame 0)
        world = axes @ np.diag(model.body_inertia[body.id]) @ axes.T
        rot = frames[i, :3, :3]
        in_frame = rot.T @ world @ rot  # inertia about the COM in DH frame i
        expected = inertia[i - 1]
        known = ~np.isnan(expected)
        np.testing.assert_allclose(np.diag(in_frame)[known], expected[known], rtol=1e-9)
        if known.all():
            np.testing.assert_allclose(in_frame - np.diag(np.diag(in_frame)), 0, atol=1e-12)
    masses = model.body_mass[[model.body(f"link{i}").id for i in range(1, 7)]]
    np.testing.assert_allclose(masses[1:], PUMA_MASS[1:], rtol=1e-12)
    assert masses[0] == PUMA_LINK1_MASS
    # Rotor inertia and viscous friction referred to the joint: Jm·G², B·G².
    dofs = [model.joint(f"joint{i + 1}").dofadr[0] for i in range(6)]
    np.testing.assert_allclose(model.dof_armature[dofs], PUMA_JM * PUMA_GEAR**2, rtol=PARAM_RTOL)
    np.testing.assert_allclose(model.dof_damping[dofs], PUMA_B * PUMA_GEAR**2, rtol=PARAM_RTOL)

    # Centres of mass along the links: link 2 at -0.3638 m along x2 (towards the shoulder), link 3
    # 0.070 m along the forearm, link 6 0.032 m from the wrist centre along the tool axis.
    def com_in_frame(i: int, frame: int) -> np.ndarray:
        offset = data.xipos[model.body(f"link{i}").id] - data.site("base").xpos
        return frames[frame, :3, :3].T @ (offset - frames[frame, :3, 3])

    assert com_in_frame(2, 2)[0] == pytest.approx(-0.3638, abs=1e-9)
    assert abs(com_in_frame(3, 3)[2]) == pytest.approx(0.070, abs=1e-9)
    assert com_in_frame(6, 5)[2] == pytest.approx(0.032, abs=1e-9)  # frame 5: wrist centre, z6


@pytest.mark.parametrize(("arm", "elbow"), [(1, 1), (1, -1), (-1, 1), (-1, -1)])
def test_puma_wrist_ik_inverts_the_wrist_centre(arm, elbow):
    p = box_lattice(PUMA_BOX_LOWER, PUMA_BOX_UPPER, 13)  # frame 0, faces and corners included
    theta, reachable = puma560.wrist_ik(p, arm, elbow)
    assert reachable.all()
    full = np.concatenate([theta, np.zeros_like(theta)], axis=-1)  # θ4..θ6 do not move frame 4
    np.testing.assert_allclose(puma_frames(full)[:, 4, :3, 3], p, atol=FK_TOL, rtol=0)
    got_arm, got_elbow = fu_indicators(theta)
    assert np.all(got_arm == arm) and np.all(got_elbow == elbow)


def test_puma_wrist_ik_flags_unreachable_points():
    a2, a3, d4 = PUMA_A_MM[1] * MM, PUMA_A_MM[2] * MM, PUMA_D_MM[3] * MM
    reach = a2 + math.hypot(d4, a3)
    d2 = PUMA_D_MM[1] * MM
    far = np.array([[0.0, d2, reach + 0.01], [0.5 * d2, 0.0, 0.0]])  # beyond reach; inside d2
    theta, reachable = puma560.wrist_ik(far, 1, 1)
    assert not reachable.any()
    assert np.all(np.isfinite(theta))


# --------------------------------------------------------------------------- RIACS


@pytest.fixture(scope="module")
def riacs_model():
    model = models.load_model("riacs")
    return model, mujoco.MjData(model)


def _riacs_joint_samples(rng: np.random.Generator, n: int) -> np.ndarray:
    """n uniform joint vectors plus the 8 corners of the joint box; (n + 8, 3)."""
    corners = np.stack(np.meshgrid(*RIACS_RANGE, indexing="ij"), axis=-1).reshape(-1, 3)
    return np.concatenate([rng.uniform(RIACS_LOWER, RIACS_UPPER, size=(n, 3)), corners])


def test_riacs_robot3df_is_the_report_and_the_chain():
    theta = _riacs_joint_samples(np.random.default_rng(90), N_FK_SAMPLES)
    report = robot3df_report(RIACS_L1, RIACS_L2, *theta.T)
    np.testing.assert_allclose(riacs_chain(theta), report, atol=1e-12, rtol=0)
    got = np.stack(riacs.robot3df(RIACS_L1, RIACS_L2, *theta.T), axis=-1)
    np.testing.assert_allclose(got, report, atol=1e-12, rtol=0)


def test_riacs_tcp_site_equals_robot3df(riacs_model):
    model, data = riacs_model
    theta = _riacs_joint_samples(np.random.default_rng(91), N_FK_SAMPLES)
    qidx = _qpos_indices(model, 3)
    tcp = []
    for q in theta:
        data.qpos[qidx] = q
        mujoco.mj_kinematics(model, data)
        tcp.append(data.site("tcp").xpos.copy())
    np.testing.assert_allclose(tcp, riacs_chain(theta), atol=FK_TOL, rtol=0)


def test_riacs_robot3dinv_inverts_robot3df():
    theta = _riacs_joint_samples(np.random.default_rng(92), N_FK_SAMPLES)
    x, y, z = riacs.robot3df(RIACS_L1, RIACS_L2, *theta.T)
    back = np.stack(riacs.robot3dinv(RIACS_L1, RIACS_L2, x, y, z), axis=-1)
    np.testing.assert_allclose(back, theta, atol=1e-12, rtol=0)


def test_riacs_camerafd_inverts_camera():
    rng = np.random.default_rng(93)
    p = rng.uniform(RIACS_BOX_LOWER, RIACS_BOX_UPPER, size=(N_FK_SAMPLES, 3))
    x1, y1, x2, y2 = riacs.camera(RIACS_FOCAL, RIACS_HALF_SEPARATION, *p.T)
    # The report's pinholes at (±d, 0, f) looking down -z, written out here.
    depth = RIACS_FOCAL - p[:, 2]
    np.testing.assert_allclose(x1, (p[:, 0] - RIACS_HALF_SEPARATION) / depth, rtol=1e-14)
    np.testing.assert_allclose(x2, (p[:, 0] + RIACS_HALF_SEPARATION) / depth, rtol=1e-14)
    np.testing.assert_allclose(y1, p[:, 1] / depth, rtol=1e-14)
    np.testing.assert_allclose(y2, y1, rtol=0)
    back = np.stack(riacs.camerafd(RIACS_FOCAL, RIACS_HALF_SEPARATION, x1, y1, x2, y2), axis=-1)
    np.testing.assert_allclose(back, p, atol=1e-12, rtol=0)


def test_riacs_ranges_and_home_are_build3dpts(riacs_model):
    model, _ = riacs_model
    ranges = np.array([model.joint(f"joint{i + 1}").range for i in range(3)])
    np.testing.assert_allclose(ranges, RIACS_RANGE, atol=MJCF_ANGLE_TOL)
    np.testing.assert_allclose(model.actuator_ctrlrange, RIACS_RANGE, atol=MJCF_ANGLE_TOL)
    np.testing.assert_allclose(riacs.LOWER, RIACS_LOWER, atol=1e-15)
    np.testing.assert_allclose(riacs.UPPER, RIACS_UPPER, atol=1e-15)
    mid = RIACS_RANGE.mean(axis=1)
    home = model.key("home")
    np.testing.assert_allclose(home.qpos[_qpos_indices(model, 3)], mid, atol=MJCF_ANGLE_TOL)
    np.testing.assert_allclose(home.ctrl, mid, atol=MJCF_ANGLE_TOL)
    assert (riacs.LINK1, riacs.LINK2) == (RIACS_L1, RIACS_L2)


# --------------------------------------------------------------------------- servo


@pytest.mark.parametrize("name", models.available_models())
def test_servo_reaches_random_poses_within_one_second(name):
    model = models.load_model(name)
    data = mujoco.MjData(model)
    qidx = _qpos_indices(model, model.nu)
    lo, hi = np.array([model.joint(f"joint{i + 1}").range for i in range(model.nu)]).T
    targets = np.random.default_rng(2024).uniform(lo, hi, size=(N_SERVO_POSES, model.nu))
    n_steps = round(SIM_SECONDS / model.opt.timestep)
    errors = np.empty_like(targets)
    for k, target in enumerate(targets):
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        data.ctrl[:] = target
        for _ in range(n_steps):
            mujoco.mj_step(model, data)
        errors[k] = data.qpos[qidx] - target
    worst = np.abs(errors).max(axis=0)
    assert np.all(worst < SERVO_TOL), f"worst error per joint after 1 s (rad): {worst}"


# --------------------------------------------------------------------------- workspaces


def test_puma_workspace_is_the_documented_box(puma):
    model, data = puma
    mujoco.mj_kinematics(model, data)
    base = data.site("base").xpos
    np.testing.assert_allclose(puma560.WORKSPACE.lower, base + PUMA_BOX_LOWER, atol=1e-12)
    np.testing.assert_allclose(puma560.WORKSPACE.upper, base + PUMA_BOX_UPPER, atol=1e-12)
    # Documented clearances: inside the reach sphere by 3 cm, away from the joint-1 axis by 0.2 m.
    corners = box_lattice(PUMA_BOX_LOWER, PUMA_BOX_UPPER, 2)
    a2, a3, d2, d4 = PUMA_A_MM[1] * MM, PUMA_A_MM[2] * MM, PUMA_D_MM[1] * MM, PUMA_D_MM[3] * MM
    reach = a2 + math.hypot(d4, a3)
    radius = np.sqrt((corners**2).sum(axis=1) - d2**2)  # distance in the arm plane, (8,)
    assert reach - radius.max() >= PUMA_REACH_MARGIN
    nearest_to_axis = np.hypot(
        np.clip(0.0, PUMA_BOX_LOWER[0], PUMA_BOX_UPPER[0]),
        np.clip(0.0, PUMA_BOX_LOWER[1], PUMA_BOX_UPPER[1]),
    )
    assert nearest_to_axis >= PUMA_AXIS_CLEARANCE


def test_puma_workspace_is_reachable_right_above_within_joint_ranges():
    """Right-above (ARM = ELBOW = +1) wrist IK, with joints 1-3 in range after ±2π shifts."""
    p = box_lattice(PUMA_BOX_LOWER, PUMA_BOX_UPPER, 21)
    theta, reachable = puma560.wrist_ik(p, 1, 1)
    assert reachable.all()
    shifts = np.array([-2 * math.pi, 0.0, 2 * math.pi])
    candidates = theta[..., None] + shifts  # (N, 3, 3)
    in_range = (candidates >= PUMA_LOWER[:3, None]) & (candidates <= PUMA_UPPER[:3, None])
    ok = in_range.any(axis=-1)  # (N, 3)
    assert ok.all(), f"{(~ok).sum(axis=0)} points out of range per joint, e.g. {p[~ok.all(-1)][:3]}"
    full = np.concatenate([theta, np.zeros_like(theta)], axis=-1)
    np.testing.assert_allclose(puma_frames(full)[:, 4, :3, 3], p, atol=FK_TOL, rtol=0)


@pytest.mark.parametrize("name", models.available_models())
def test_workspace_sampling_is_seeded(name):
    workspace = robot_model(name).workspace
    a = workspace.sample(np.random.default_rng(7), 500)
    b = workspace.sample(np.random.default_rng(7), 500)
    c = workspace.sample(np.random.default_rng(8), 500)
    assert a.shape == (500, 3)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


def test_puma_workspace_samples_are_uniform_in_the_box():
    ws = puma560.WORKSPACE
    p = ws.sample(np.random.default_rng(11), N_WORKSPACE_SAMPLES)
    base = np.array([0.0, 0.0, PUMA_BASE_HEIGHT])
    lower, upper = base + PUMA_BOX_LOWER, base + PUMA_BOX_UPPER
    assert np.all((p >= lower) & (p <= upper))
    sigma = math.sqrt((1 / 8) * (7 / 8) / len(p))  # binomial spread of one octant's fraction
    np.testing.assert_allclose(octant_fractions(p, lower, upper), 1 / 8, atol=5 * sigma)
    # A uniform box has mean at the centre and variance (side²)/12 per axis.
    side = upper - lower
    mean_spread = side / math.sqrt(12 * len(p))  # standard error of each axis' mean, (3,)
    assert np.all(np.abs(p.mean(axis=0) - (lower + upper) / 2) <= 5 * mean_spread)
    np.testing.assert_allclose(p.var(axis=0), side**2 / 12, rtol=0.05)


def test_riacs_bounding_box_encloses_the_reachable_set():
    t = [np.linspace(lo, hi, 40) for lo, hi in RIACS_RANGE]
    theta = np.stack(np.meshgrid(*t, indexing="ij"), axis=-1).reshape(-1, 3)
    p = robot3df_report(RIACS_L1, RIACS_L2, *theta.T)
    np.testing.assert_array_equal(riacs.WORKSPACE.lower, RIACS_BOX_LOWER)
    np.testing.assert_array_equal(riacs.WORKSPACE.upper, RIACS_BOX_UPPER)
    assert np.all(p >= RIACS_BOX_LOWER) and np.all(p <= RIACS_BOX_UPPER)
    # ... and tightly: every face is touched within 1 cm.
    np.testing.assert_allclose(p.min(axis=0), RIACS_BOX_LOWER, atol=0.01)
    np.testing.assert_allclose(p.max(axis=0), RIACS_BOX_UPPER, atol=0.01)


def test_riacs_workspace_samples_are_reachable_and_uniform():
    ws = riacs.WORKSPACE
    p = ws.sample(np.random.default_rng(12), N_WORKSPACE_SAMPLES)
    theta = np.stack(riacs.robot3dinv(RIACS_L1, RIACS_L2, *p.T), axis=-1)
    assert np.all((theta >= RIACS_LOWER) & (theta <= RIACS_UPPER))
    assert riacs_reachable(p).all()
    # Monte-Carlo volume of each octant of the bounding box from a dense grid of cell centres.
    cells = grid(RIACS_BOX_LOWER, RIACS_BOX_UPPER, 48)
    inside = cells[riacs_reachable(cells)]
    expected = octant_fractions(inside, RIACS_BOX_LOWER, RIACS_BOX_UPPER)
    got = octant_fractions(p, RIACS_BOX_LOWER, RIACS_BOX_UPPER)
    sigma = np.sqrt(expected * (1 - expected) / len(p))
    grid_error = 0.002  # the 48³ grid's own error in an octant's share of the volume
    assert np.all(np.abs(got - expected) <= 5 * sigma + grid_error), (got, expected)
