"""``terminate_on_success``: an episode ends at its first successful move, judged against the
ground truth computed here, and never without the option."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (registers the envs)
from envs.reach import SUCCESS_THRESHOLD

FAST = {"sensing": "project", "control": "kinematic"}


def exact_move(env: gym.Env) -> np.ndarray:
    """Joints that put the arm's sensed point on the target: the reach task's inverse kinematics
    (RIACS) or the grasp task's solution for the object (PUMA grasp)."""
    base = env.unwrapped
    if hasattr(base, "target_joints"):
        return base.target_joints.copy()
    return base.robot_spec.workspace.ik(base.data.mocap_pos[base.target_mocap_id][None])[0]


@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaGrasp-v0"])
def test_an_episode_ends_at_its_first_successful_move_only_when_asked(env_id):
    for terminate in (False, True):
        env = gym.make(env_id, terminate_on_success=terminate, **FAST)
        rng = np.random.default_rng(0)
        space = env.action_space
        env.reset(seed=1)
        for _ in range(12):
            _, _, terminated, _, info = env.step(rng.uniform(space.low, space.high))
            hit = np.linalg.norm(info["target_pos"] - info["effector_pos"]) < SUCCESS_THRESHOLD
            assert not hit  # random moves miss the target by far more than 5 mm
            assert terminated is False
            env.reset()
        _, _, terminated, _, info = env.step(exact_move(env))
        distance = np.linalg.norm(info["target_pos"] - info["effector_pos"])
        assert distance < 1e-6 and info["is_success"]
        assert terminated is terminate  # a plain bool, as Gymnasium's checker wants
        env.close()


def test_the_env_checker_passes_with_termination():
    env = gym.make("RiacsReach-v0", terminate_on_success=True, **FAST)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_a_wrong_value_names_the_argument():
    with pytest.raises(ValueError, match="terminate_on_success is 'yes', not True or False"):
        gym.make("RiacsReach-v0", terminate_on_success="yes", **FAST)
