"""Gymnasium environments and stereo camera sensing.

Importing this package chooses the off-screen GL back-end (before mujoco is imported) and
registers ``RiacsReach-v0``, ``PumaReach-v0``, ``PumaGrasp-v0`` and ``PumaTrack-v0`` with
Gymnasium. ``gym.make`` returns the reach and pose envs in :class:`envs.goal_env.GoalEnvWrapper`,
which has ``compute_reward``.
"""

from envs.sensing.rendering import configure_gl_backend

configure_gl_backend()

import gymnasium as gym  # noqa: E402

from envs.goal_env import GOAL_ENV_WRAPPER  # noqa: E402
from envs.reach import MAX_EPISODE_STEPS, ReachEnv  # noqa: E402
from envs.sensing.stereo import StereoRig  # noqa: E402
from models.paths import N_STEPS  # noqa: E402

gym.register(
    id="RiacsReach-v0",
    entry_point="envs.reach:ReachEnv",
    kwargs={"robot": "riacs"},
    max_episode_steps=MAX_EPISODE_STEPS,
    additional_wrappers=(GOAL_ENV_WRAPPER,),  # compute_reward on what gym.make returns
)
gym.register(
    id="PumaReach-v0",
    entry_point="envs.reach:ReachEnv",
    kwargs={"robot": "puma560"},
    max_episode_steps=MAX_EPISODE_STEPS,
    additional_wrappers=(GOAL_ENV_WRAPPER,),  # compute_reward on what gym.make returns
)
gym.register(
    id="PumaGrasp-v0",
    entry_point="envs.grasp:GraspEnv",
    max_episode_steps=MAX_EPISODE_STEPS,
    additional_wrappers=(GOAL_ENV_WRAPPER,),  # compute_reward on what gym.make returns
)
gym.register(
    id="PumaTrack-v0",
    entry_point="envs.track:PumaTrackEnv",
    max_episode_steps=N_STEPS,  # one path; gym.make(..., n_steps=n, max_episode_steps=n) for others
)

__all__ = ["ReachEnv", "StereoRig"]
