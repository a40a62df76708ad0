"""The grasp task's floors through the idealised cameras: exact pose IK and damped least squares,
measured against the oracle's exact poses."""

from __future__ import annotations

import numpy as np
import pytest

from envs.studies.grasp_oracle import PoseOracle
from learners.baselines.pose_ik import PoseIK, PoseJacobianIK
from models.puma560 import BASE_POS
from models.rotations import rotvec_to_matrix

TARGETS = 40


@pytest.fixture(scope="module")
def oracle() -> PoseOracle:
    return PoseOracle()


@pytest.fixture(scope="module")
def targets(oracle):
    poses, joints = oracle.targets(np.random.default_rng(0), TARGETS)
    return poses, joints, oracle.pixels(poses)


def _run(controller, oracle, poses, pixels, fine_moves=1):
    """Errors (position m, orientation rad) (N, 1 + fine_moves) of every move of every target."""
    position, orientation = [], []
    for pose, u in zip(poses, pixels, strict=True):
        controller.reset()
        theta = controller.act(u)
        moves = [theta]
        for _ in range(fine_moves):
            theta = controller.act(u, oracle.hand_pixels(theta))
            moves.append(theta)
        p, a = oracle.errors(pose, np.array(moves))
        position.append(p)
        orientation.append(a)
    return np.array(position), np.array(orientation)


@pytest.mark.parametrize("kind", [PoseIK, PoseJacobianIK])
def test_floor_is_exact_through_exact_cameras(kind, oracle, targets):
    poses, _, pixels = targets
    controller = kind(oracle.cameras.triangulate, BASE_POS)
    position, orientation = _run(controller, oracle, poses, pixels)
    assert position.max() < 1e-6 and orientation.max() < 1e-6, (position.max(), orientation.max())
    assert controller.last_reachable


def test_pose_ik_keeps_the_branch_of_the_current_joints(oracle, targets):
    """From READY the nearest branch is READY's: the sampler's joints come back exactly."""
    _, joints, pixels = targets
    ik = PoseIK(oracle.cameras.triangulate, BASE_POS)
    for theta, u in zip(joints, pixels, strict=True):
        ik.reset()
        np.testing.assert_allclose(ik.act(u), theta, atol=1e-9)


def test_jacobian_ik_converges_from_ready(oracle, targets):
    _, joints, pixels = targets
    dls = PoseJacobianIK(oracle.cameras.triangulate, BASE_POS)
    for theta, u in zip(joints, pixels, strict=True):
        dls.reset()
        np.testing.assert_allclose(dls.act(u), theta, atol=1e-7)
        assert dls.last_reachable and 0 < dls.last_iterations < 200


@pytest.mark.parametrize("kind", [PoseIK, PoseJacobianIK])
def test_fine_move_cancels_a_rigid_sensing_bias(kind, oracle, targets):
    """Cameras whose triangulation is off by a rigid motion (3 cm, 2°) put the coarse move off by
    about that much; the fine move re-aims by the sensed hand-to-object transform, in which the
    bias cancels."""
    rotation = rotvec_to_matrix(np.radians(2.0) * np.array([0.6, 0.0, 0.8]))
    shift = np.array([0.03, -0.01, 0.02])
    centre = BASE_POS + np.array([0.0, 0.5, 0.0])

    def biased(pixels):
        return (oracle.cameras.triangulate(pixels) - centre) @ rotation.T + centre + shift

    poses, _, pixels = targets
    position, orientation = _run(kind(biased, BASE_POS), oracle, poses[:10], pixels[:10], 2)
    assert position[:, 0].min() > 0.005 and np.degrees(orientation[:, 0]).min() > 1.5
    assert position[:, 2].max() < 1e-6 and orientation[:, 2].max() < 1e-6


@pytest.mark.parametrize("kind", [PoseIK, PoseJacobianIK])
def test_bad_input_is_one_line_value_error(kind, oracle, targets):
    controller = kind(oracle.cameras.triangulate, BASE_POS)
    u = targets[2][0]
    for bad in (u[:4], np.where(np.arange(12) == 3, np.nan, u)):
        with pytest.raises(ValueError) as error:
            controller.act(bad)
        assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match="coarse act"):
        controller.act(u, u)
    with pytest.raises(ValueError, match="6 finite joint angles"):
        kind(oracle.cameras.triangulate, BASE_POS, start=np.zeros(3))


@pytest.mark.parametrize("orientations", ["ball:30", "yaw:90,tilt:45"])
def test_the_floor_commands_inside_the_action_box_and_grasps_every_object(orientations):
    """Through the env (the default task box as action space), the exact pose IK picks a
    branch inside the box: every object grasped to 1e-6 m and rad, no command clipped. Over the
    joint ranges alone its nearest branch can lie outside the box (the other wrist flip), and
    the env's clipping then sends the hand elsewhere."""
    from envs.cli.controllers import make_pose_floor
    from envs.grasp import GraspEnv

    env = GraspEnv(sensing="project", control="kinematic", orientations=orientations)
    floor = make_pose_floor("pose_ik", env)
    env.reset(seed=5)
    for _ in range(150):
        env.reset()
        floor.reset()
        command = floor.act(env.sensed_target())
        assert np.all(command >= env.action_lower) and np.all(command <= env.action_upper)
        _, _, _, _, info = env.step(command)
        assert not info["clipped"]
        assert info["distance"] < 1e-6 and info["orientation_error"] < 1e-6
    env.close()
