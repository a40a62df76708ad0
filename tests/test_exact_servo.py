"""ExactServo: its pixel Jacobian against finite differences of the projected kinematics, and
Newton-like convergence of its fine moves with exact projection."""

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the envs)
from learners.baselines.analytic_ik import AnalyticIK
from learners.baselines.exact_servo import ExactServo


@pytest.fixture(scope="module", params=["RiacsReach-v0", "PumaReach-v0"])
def setup(request):
    env = gym.make(request.param, sensing="project", control="kinematic")
    base = env.unwrapped
    ik = AnalyticIK.for_robot(base.nominal_stereo.triangulate, base.robot, joints=base.joints)
    yield ExactServo(ik, base.nominal_stereo.project), base
    env.close()


def pixels_of(servo: ExactServo, theta: np.ndarray) -> np.ndarray:
    return servo.project(servo.ik.arm.forward(theta[None]))[0]


def test_pixel_jacobian_equals_central_differences_in_joint_space(setup):
    servo, _ = setup
    arm, h = servo.ik.arm, 1e-5
    for theta in np.random.default_rng(0).uniform(arm.lower, arm.upper, size=(5, arm.n_joints)):
        numeric = np.stack(
            [(pixels_of(servo, theta + h * e) - pixels_of(servo, theta - h * e)) / (2 * h)
             for e in np.eye(arm.n_joints)], axis=1,
        )  # fmt: skip
        np.testing.assert_allclose(servo.pixel_jacobian(theta), numeric, rtol=1e-5, atol=1e-3)


def test_fine_moves_converge_to_second_order(setup):
    """From 0.02 rad off the target's pose, with exact pixels each fine move is a Newton step:
    it leaves a few thousandths of the error (measured: at most 0.03, 0.5 % typical), where
    the map's moves leave 0.15-0.2."""
    servo, base = setup
    arm = servo.ik.arm
    targets = base.robot_spec.workspace.sample(np.random.default_rng(1), 20)
    poses, _ = arm.inverse(targets, None)
    offsets = np.random.default_rng(2).normal(0.0, 0.02, poses.shape)
    for pose, offset in zip(poses, offsets, strict=True):
        u = pixels_of(servo, pose)
        servo.reset()
        servo.act(u)
        command = servo._cmd = np.clip(pose + offset, arm.lower, arm.upper)  # a missed coarse move
        errors = []
        for _ in range(3):
            v = pixels_of(servo, command)
            errors.append(np.linalg.norm(u - v))
            command = servo.act(u, v)
        e0, e1, e2 = errors
        assert e1 < 0.05 * e0 and e2 < 0.05 * e1


def test_a_fine_move_before_a_coarse_one_is_refused(setup):
    servo, _ = setup
    servo.reset()
    with pytest.raises(ValueError, match="coarse act"):
        servo.act(np.zeros(4), np.zeros(4))
