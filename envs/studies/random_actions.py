"""How often uniformly random actions leave the hand in both cameras' views (PumaGrasp-v0).

An RL client's first steps are random actions; where they mostly leave the hand unseen, the
reward's flat unseen penalty is all it learns from. This counts, over episodes of
``steps`` random actions (``env.action_space.sample()``, seeded), the share of moves after which
both cameras saw all three hand markers (``info["visible_effector"]``)::

    .venv/bin/python -m envs.studies.random_actions            # the table of the env page
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.harness.streams import seed_env

#: (sensing, action_range, moves) of the env page's table.
SETTINGS = (
    ("project", "task", 2000),
    ("project", "joints", 2000),
    ("render", "task", 800),
    ("render", "joints", 800),
)


def visible_share(
    moves: int, seed: int = 0, steps: int = 4, env_id: str = "PumaGrasp-v0", **kwargs: object
) -> float:
    """The share of ``moves`` random moves (episodes of ``steps``; targets from the validation
    stream of ``seed``, actions from the action space seeded with ``seed``) after which both
    cameras saw every hand marker."""
    env = gym.make(env_id, control="kinematic", **kwargs)
    seed_env(env, seed, "validation")
    env.action_space.seed(seed)
    seen = 0
    try:
        for move in range(moves):
            if move % steps == 0:
                env.reset()
            _, _, _, _, info = env.step(env.action_space.sample())
            seen += bool(np.all(info["visible_effector"]))
    finally:
        env.close()
    return seen / moves


def main() -> None:
    print("| action range | sensing | moves | hand seen by both cameras |")
    print("|---|---|---|---|")
    for sensing, action_range, moves in SETTINGS:
        share = visible_share(moves, sensing=sensing, action_range=action_range)
        print(f"| `{action_range}` | `{sensing}` | {moves} | {100 * share:.1f} % |")


if __name__ == "__main__":
    main()
