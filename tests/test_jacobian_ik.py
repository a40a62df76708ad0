"""JacobianIK: damped least squares converges to the target, stays in the joint ranges, starts from
the previous command; the arms' Jacobians equal finite differences of their forward kinematics."""

import numpy as np
import pytest

from learners.baselines.jacobian_ik import JacobianIK
from models import puma560, riacs
from models.robot_model import robot_model

WORKSPACES = {name: robot_model(name).workspace for name in ("puma560", "riacs")}


def identity_triangulate(pixels: np.ndarray) -> np.ndarray:
    """Stand-in for the stereo rig: the first three 'pixels' are the world point."""
    return np.asarray(pixels)[:, :3]


def as_pixels(points: np.ndarray) -> np.ndarray:
    return np.concatenate([points, np.zeros((len(points), 1))], axis=1)


def puma_wrist_centre(theta: np.ndarray) -> np.ndarray:
    """World wrist centre from Brause (5.6), written out here."""
    t1, t2, t3 = theta.T
    a2, a3, d2, d4 = 0.4318, -0.02032, 0.14909, 0.43307
    reach = a2 * np.cos(t2) + a3 * np.cos(t2 + t3) + d4 * np.sin(t2 + t3)
    p = np.stack(
        [
            np.cos(t1) * reach - d2 * np.sin(t1),
            np.sin(t1) * reach + d2 * np.cos(t1),
            d4 * np.cos(t2 + t3) - a3 * np.sin(t2 + t3) - a2 * np.sin(t2),
        ],
        axis=-1,
    )
    return p + np.array([0.0, 0.0, 0.6718])


@pytest.mark.parametrize("robot", ["puma560", "riacs"])
def test_converges_to_targets_inside_the_ranges(robot):
    targets = WORKSPACES[robot].sample(np.random.default_rng(10), 400)
    controller = JacobianIK.for_robot(identity_triangulate, robot)
    theta = controller.act_batch(as_pixels(targets))
    assert controller.last_reachable.all()
    arm = controller.arm
    assert np.all((theta >= arm.lower) & (theta <= arm.upper))
    if robot == "puma560":
        reached = puma_wrist_centre(theta)
    else:
        reached = np.stack(riacs.robot3df(0.6, 0.4, *theta.T), axis=-1)
    assert np.max(np.linalg.norm(reached - targets, axis=1)) < 1e-7


def test_iterates_from_the_previous_command_and_reset_returns_to_start():
    start = riacs.HOME + 0.05
    controller = JacobianIK.for_robot(identity_triangulate, "riacs", start=start)
    targets = riacs.WORKSPACE.sample(np.random.default_rng(11), 3)
    first = controller.act(as_pixels(targets[:1])[0])
    np.testing.assert_array_equal(controller.previous, first)
    # The same target again from the converged command: no iteration needed.
    again = controller.act(as_pixels(targets[:1])[0])
    assert controller.last_iterations == 0
    np.testing.assert_array_equal(again, first)
    # A fine move re-solves from there: the same command.
    fine = controller.act(as_pixels(targets[:1])[0], np.zeros(4))
    np.testing.assert_array_equal(fine, first)
    controller.act(as_pixels(targets[1:2])[0])
    controller.reset()
    np.testing.assert_array_equal(controller.previous, start)


def test_joint_ranges_are_respected_for_a_target_outside_them():
    # RIACS target with x < 0 needs θ1 < 0: the iteration must stop at θ1 = lower bound.
    controller = JacobianIK.for_robot(identity_triangulate, "riacs")
    theta = controller.act(np.array([-0.3, 0.5, 0.1, 0.0]))
    assert controller.last_reachable is False
    assert np.all(np.isfinite(theta))
    arm = controller.arm
    assert np.all((theta >= arm.lower) & (theta <= arm.upper))
    assert theta[0] == pytest.approx(arm.lower[0])


@pytest.mark.parametrize("robot", ["puma560", "riacs"])
def test_unreachable_targets_are_reported_and_never_nan(robot):
    far = np.array([[5.0, 5.0, 5.0], [0.0, 0.0, 0.0], [-2.0, -1.0, 3.0]])
    controller = JacobianIK.for_robot(identity_triangulate, robot, max_iterations=30)
    theta = controller.act_batch(as_pixels(far))
    assert not controller.last_reachable.any()
    arm = controller.arm
    assert np.all(np.isfinite(theta)) and np.all((theta >= arm.lower) & (theta <= arm.upper))


@pytest.mark.parametrize(
    "arm",
    [puma560.arm.wrist(), puma560.arm.tool(), riacs.arm.tool()],
    ids=["wrist", "tool", "riacs"],
)
def test_jacobian_equals_central_difference(arm):
    rng = np.random.default_rng(12)
    theta = rng.uniform(arm.lower, arm.upper, size=(20, arm.n_joints))
    h = 1e-6
    numeric = np.stack(
        [
            (arm.forward(theta + h * e) - arm.forward(theta - h * e)) / (2 * h)
            for e in np.eye(arm.n_joints)
        ],
        axis=-1,
    )  # (20, 3, J)
    analytic = arm.jacobian(theta)
    scale = np.max(np.abs(numeric))
    np.testing.assert_allclose(analytic, numeric, rtol=1e-6, atol=1e-6 * scale)


def test_invalid_options_raise():
    with pytest.raises(ValueError, match="damping"):
        JacobianIK.for_robot(identity_triangulate, "riacs", damping=0.0)
    with pytest.raises(ValueError, match="start must have shape"):
        JacobianIK.for_robot(identity_triangulate, "riacs", start=np.zeros(6))
