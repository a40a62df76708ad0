"""AnalyticIK and the closed-form inverse kinematics: FK(IK(p)) = p with an independent forward
kinematics written here, all PUMA configurations and wrist flips, unreachable targets."""

import mujoco
import numpy as np
import pytest

from envs import StereoRig
from learners.baselines.analytic_ik import AnalyticIK
from models import arms, load_model, puma560, riacs
from models.joints import wrap_into_range
from models.puma560.inverse import BRANCHES, pose_ik, pose_ik_all

DEG = np.pi / 180
# PUMA DH of Brause Fig. 2b, typed again: (alpha deg, a m, d m)
PUMA_DH = [
    (-90, 0, 0),
    (0, 0.4318, 0.14909),
    (90, -0.02032, 0),
    (-90, 0, 0.43307),
    (90, 0, 0),
    (0, 0, 0.05625),
]
PUMA_LOWER = np.array([-160, -225, -45, -110, -100, -266]) * DEG
PUMA_UPPER = np.array([160, 45, 225, 170, 100, 266]) * DEG


def puma_fk(theta: np.ndarray, upto: int) -> np.ndarray:
    """T_0,upto by multiplying A_i = Rz Tz Tx Rx written out here, one pose at a time."""
    out = []
    for row in np.atleast_2d(theta):
        T = np.eye(4)
        for i in range(upto):
            alpha, a, d = PUMA_DH[i]
            ct, st = np.cos(row[i]), np.sin(row[i])
            ca, sa = np.cos(alpha * DEG), np.sin(alpha * DEG)
            A = np.array(
                [
                    [ct, -st * ca, st * sa, a * ct],
                    [st, ct * ca, -ct * sa, a * st],
                    [0, sa, ca, d],
                    [0, 0, 0, 1],
                ]
            )
            T = T @ A
        out.append(T)
    return np.array(out)


def riacs_fk(theta: np.ndarray) -> np.ndarray:
    """Tool point from the geometry: link 1 at elevation θ2, link 2 folded back by θ3."""
    t1, t2, t3 = theta.T
    rho = 0.6 * np.cos(t2) - 0.4 * np.cos(t2 + t3)
    z = 0.6 * np.sin(t2) - 0.4 * np.sin(t2 + t3)
    return np.stack([rho * np.sin(t1), rho * np.cos(t1), z], axis=-1)


@pytest.fixture(scope="module")
def rigs():
    out = {}
    for name in ("puma560", "riacs"):
        model = load_model(name)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        out[name] = StereoRig(model, data)
    yield out
    for rig in out.values():
        rig.close()


@pytest.mark.parametrize("configuration", list(puma560.kinematics.CONFIGURATIONS))
def test_puma_wrist_ik_reaches_every_target_in_each_configuration(configuration):
    rng = np.random.default_rng(1)
    # Points over the whole reach, not only the target box: each configuration reaches part.
    points = puma560.BASE_POS + rng.uniform([-0.8, -0.8, -0.8], [0.8, 0.8, 0.8], (4000, 3))
    arm = puma560.arm.wrist(configuration)
    theta, reachable = arm.inverse(points, None)
    assert reachable.mean() > 0.2  # the check below is not vacuous
    assert np.all(np.isfinite(theta))
    full = np.concatenate([theta, np.zeros_like(theta)], axis=1)
    reached = puma560.BASE_POS + puma_fk(full, 4)[:, :3, 3]
    assert np.max(np.abs(reached - points)[reachable]) < 1e-9
    assert np.all((theta >= PUMA_LOWER[:3]) & (theta <= PUMA_UPPER[:3]))


def test_puma_right_above_reaches_the_whole_target_box():
    points = puma560.WORKSPACE.sample(np.random.default_rng(2), 3000)
    _, reachable = puma560.arm.wrist("right-above").inverse(points, None)
    assert reachable.all()


def test_puma_full_pose_all_eight_solutions():
    rng = np.random.default_rng(3)
    theta = rng.uniform(PUMA_LOWER, PUMA_UPPER, size=(400, 6))
    T = puma_fk(theta, 6)
    solutions, valid = pose_ik_all(T)  # (400, 8, 6), (400, 8)
    assert solutions.shape == (400, 8, 6) and np.all(np.isfinite(solutions))
    assert valid.sum() > 1000  # several branches per pose on average
    reached = puma_fk(solutions.reshape(-1, 6), 6).reshape(400, 8, 4, 4)
    error = np.abs(reached - T[:, None]).max(axis=(-1, -2))
    assert np.max(error[valid]) < 1e-9  # position (m) and rotation entries
    assert np.all((solutions >= PUMA_LOWER) & (solutions <= PUMA_UPPER))
    # The joints we started from are one of the valid solutions (modulo 2π).
    gap = np.abs(np.angle(np.exp(1j * (solutions - theta[:, None])))).max(axis=-1)
    assert np.all(np.min(np.where(valid, gap, np.inf), axis=1) < 1e-7)


def test_wrist_flip_is_theta4_plus_pi_minus_theta5_theta6_plus_pi():
    rng = np.random.default_rng(4)
    theta = rng.uniform(PUMA_LOWER, PUMA_UPPER, size=(200, 6))
    T = puma_fk(theta, 6)
    a, valid_a = pose_ik(T, 1, 1, 1)
    b, valid_b = pose_ik(T, 1, 1, -1)
    both = valid_a & valid_b  # elsewhere a range clipped one of them
    assert both.sum() > 20
    a, b = a[both], b[both]
    np.testing.assert_allclose(b[:, :3], a[:, :3], atol=1e-12)
    flipped = a[:, 3:] + np.array([np.pi, 0, np.pi])
    flipped[:, 1] *= -1
    np.testing.assert_allclose(np.angle(np.exp(1j * (b[:, 3:] - flipped))), 0, atol=1e-9)
    assert len(BRANCHES) == 8


def test_riacs_inverse_is_exact_to_1e12():
    points = riacs.WORKSPACE.sample(np.random.default_rng(5), 5000)
    theta, reachable = riacs.arm.tool().inverse(points, None)
    assert reachable.all()
    assert np.max(np.abs(riacs_fk(theta) - points)) < 1e-12


@pytest.mark.parametrize("robot", ["puma560", "riacs"])
def test_analytic_ik_through_the_cameras_reaches_the_target(rigs, robot):
    rig = rigs[robot]
    workspace = puma560.WORKSPACE if robot == "puma560" else riacs.WORKSPACE
    targets = workspace.sample(np.random.default_rng(6), 500)
    controller = AnalyticIK.for_robot(rig.triangulate, robot)
    theta = controller.act_batch(rig.project(targets))
    assert controller.last_reachable.all()
    if robot == "puma560":
        full = np.concatenate([theta, np.zeros_like(theta)], axis=1)
        reached = puma560.BASE_POS + puma_fk(full, 4)[:, :3, 3]
    else:
        reached = riacs_fk(theta)
    assert np.max(np.linalg.norm(reached - targets, axis=1)) < 1e-9
    single = controller.act(rig.project(targets[:1])[0])
    np.testing.assert_array_equal(single, theta[0])
    assert controller.last_reachable is True
    # The fine move re-solves: same command.
    np.testing.assert_array_equal(controller.act(rig.project(targets[:1])[0], np.zeros(4)), single)


def test_puma_six_joint_tool_point_with_tool_down(rigs):
    controller = AnalyticIK.for_robot(rigs["puma560"].triangulate, "puma560", joints=6)
    targets = puma560.WORKSPACE.sample(np.random.default_rng(7), 300)
    theta = controller.act_batch(rigs["puma560"].project(targets))
    ok = controller.last_reachable
    assert ok.mean() > 0.95
    T = puma_fk(theta[ok], 6)
    np.testing.assert_allclose(puma560.BASE_POS + T[:, :3, 3], targets[ok], atol=1e-9)
    np.testing.assert_allclose(T[:, :3, 2], np.tile([0, 0, -1], (ok.sum(), 1)), atol=1e-9)


UNREACHABLE = {  # world points, m
    "puma560": [
        [0.0, 0.0, 0.0],  # on the floor below the base, inside the d2 cylinder
        [5.0, 5.0, 5.0],  # far away
        [0.0, 0.0, 0.6718],  # the shoulder itself
        [0.02, 0.01, 0.70],  # next to the joint-1 axis
        [0.3, 0.3, 1.6],  # above, beyond the 0.88 m reach
    ],
    "riacs": [
        [0.0, 0.0, 0.0],  # the shoulder itself
        [5.0, 5.0, 5.0],  # far away
        [-0.5, -0.5, 0.2],  # outside the quadrant θ1 ∈ [0, π/2]
        [0.05, 0.05, 0.05],  # closer than |link1 - link2|
        [0.02, 0.01, 0.70],  # needs θ2 above its range
    ],
}


@pytest.mark.parametrize("robot,joints", [("puma560", 3), ("puma560", 6), ("riacs", 3)])
def test_unreachable_targets_are_reported_and_never_nan(robot, joints):
    controller = AnalyticIK(lambda px: px[:, :3], arms.arm_kinematics(robot, joints))
    points = np.array(UNREACHABLE[robot])
    U = np.concatenate([points, np.zeros((len(points), 1))], axis=1)
    theta = controller.act_batch(U)
    assert not controller.last_reachable.any()
    assert np.all(np.isfinite(theta))
    arm = controller.arm
    assert np.all((theta >= arm.lower) & (theta <= arm.upper))
    for u in U:
        command = controller.act(u)
        assert controller.last_reachable is False and np.all(np.isfinite(command))


def test_wrap_into_range_uses_other_turns_and_reference():
    lower, upper = PUMA_LOWER[[2, 5]], PUMA_UPPER[[2, 5]]  # joint 3: -45..225, joint 6: ±266
    theta = np.array([[-170 * DEG, 100 * DEG]])
    wrapped, ok = wrap_into_range(theta, lower, upper)
    np.testing.assert_allclose(wrapped, [[190 * DEG, 100 * DEG]])
    assert ok.all()
    near, _ = wrap_into_range(theta, lower, upper, reference=np.array([0.0, -200 * DEG]))
    np.testing.assert_allclose(near, [[190 * DEG, -260 * DEG]])
    clipped, ok = wrap_into_range(np.array([[-90 * DEG, 0.0]]), lower, upper)
    np.testing.assert_allclose(clipped, [[-45 * DEG, 0.0]])
    assert not ok.any()


def test_bad_arguments_raise_with_the_valid_options():
    with pytest.raises(ValueError, match="right-above"):
        puma560.arm.wrist("sideways")
    with pytest.raises(ValueError, match="valid for riacs: 3 joints"):
        arms.arm_kinematics("riacs", 6)
    with pytest.raises(ValueError, match="available models: panda, puma560, riacs, ur5e"):
        arms.arm_kinematics("kuka", 3)
    controller = AnalyticIK(lambda px: px[:, :3], riacs.arm.tool())
    with pytest.raises(ValueError, match="shape"):
        controller.act(np.zeros(3))
    with pytest.raises(ValueError, match="NaN"):
        controller.act(np.array([0.1, 0.2, np.nan, 0.0]))
