"""The visuomotor map against SB3's SAC + HER, SAC and PPO: learning curves on held-out targets.

The program is :mod:`envs.cli.compare_rl` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.compare_rl import run

if __name__ == "__main__":
    run()
