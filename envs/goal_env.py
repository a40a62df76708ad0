"""The outermost wrapper of the registered reach envs: their goal-env method where agents look.

Gymnasium's wrappers no longer forward attributes, so ``compute_reward`` of an env made by
``gym.make`` (inside ``PassiveEnvChecker``, ``OrderEnforcing`` and ``TimeLimit``) is only reachable
as ``env.unwrapped.compute_reward``. Goal-relabelling code (Stable-Baselines3's ``check_env`` and
``HerReplayBuffer``) calls it on the env it was given. The reach envs are registered with this
wrapper as their ``additional_wrappers``, which ``gym.make`` applies last, so the env it returns
has the method; ``env.spec`` records the wrapper, and ``gym.make(env.spec)`` makes it again.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np


class GoalEnvWrapper(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Passes everything through and adds ``compute_reward``, the unwrapped env's."""

    def __init__(self, env: gym.Env) -> None:
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> float | np.ndarray:
        """The unwrapped env's ``compute_reward`` (see :class:`envs.reach.ReachEnv`)."""
        return self.unwrapped.compute_reward(achieved_goal, desired_goal, info)


#: How a registration names the wrapper (``gym.register(..., additional_wrappers=...)``).
GOAL_ENV_WRAPPER = gym.envs.registration.WrapperSpec(
    name=GoalEnvWrapper.__name__, entry_point=f"{__name__}:GoalEnvWrapper", kwargs={}
)
