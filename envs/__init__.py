"""Gymnasium environments and stereo camera sensing.

Importing this package chooses the off-screen GL back-end (before mujoco is imported) and
registers ``RiacsReach-v0``, ``PumaReach-v0``, ``PumaGrasp-v0``, ``PumaTrack-v0``, the generated
arms' envs (``Ur5eReach-v0``, ``Ur5eGrasp-v0``, ``PandaReach-v0``, ``PandaGrasp-v0``) and
``ArmReach-v0`` (a user's MJCF, :mod:`envs.arm_reach`) with
Gymnasium: every robot's reach env and grasp env from the registry (:data:`envs.robots.ROBOTS`,
:func:`register_robot`), and the PUMA's path-tracking env. ``gym.make`` returns the reach and
grasp envs in :class:`envs.goal_env.GoalEnvWrapper`, which has ``compute_reward``.
"""

from envs.sensing.rendering import configure_gl_backend

configure_gl_backend()

import gymnasium as gym  # noqa: E402

from envs.goal_env import GOAL_ENV_WRAPPER  # noqa: E402
from envs.reach import MAX_EPISODE_STEPS, ReachEnv  # noqa: E402
from envs.robots import ROBOTS  # noqa: E402
from envs.sensing.stereo import StereoRig  # noqa: E402
from models.paths import N_STEPS  # noqa: E402


def register_robot(robot: str) -> None:
    """Register the envs of ``ROBOTS[robot]`` with Gymnasium: its reach env
    (``envs.reach:ReachEnv`` with ``robot`` and its fewest controlled joints; ``gym.make(...,
    joints=n)`` for others), and its grasp env (``envs.grasp:GraspEnv`` with ``robot``) if it has
    one. Importing
    ``envs`` does it for every robot; call it for an entry added later."""
    spec = ROBOTS[robot]
    gym.register(
        id=spec.reach_env,
        entry_point="envs.reach:ReachEnv",
        kwargs={"robot": robot, "joints": spec.joint_options[0]},
        max_episode_steps=MAX_EPISODE_STEPS,
        additional_wrappers=(GOAL_ENV_WRAPPER,),  # compute_reward on what gym.make returns
    )
    if spec.grasp_env is not None:
        gym.register(
            id=spec.grasp_env,
            entry_point="envs.grasp:GraspEnv",
            kwargs={"robot": robot},
            max_episode_steps=MAX_EPISODE_STEPS,
            additional_wrappers=(GOAL_ENV_WRAPPER,),  # compute_reward on what gym.make returns
        )


for _robot in ROBOTS:
    register_robot(_robot)
gym.register(  # the reach task on a user's MJCF (gym.make(..., robot=, joints=, effector_site=))
    id="ArmReach-v0",
    entry_point="envs.arm_reach:ArmReachEnv",
    max_episode_steps=MAX_EPISODE_STEPS,
    additional_wrappers=(GOAL_ENV_WRAPPER,),
)
gym.register(
    id="PumaTrack-v0",
    entry_point="envs.track:PumaTrackEnv",
    max_episode_steps=N_STEPS,  # one path; gym.make(..., n_steps=n, max_episode_steps=n) for others
)

__all__ = ["ReachEnv", "StereoRig", "register_robot"]
