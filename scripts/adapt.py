"""Re-adaptation after a change of the scene: the learned map against the stale exact baselines.

The program is :mod:`envs.cli.adapt` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.adapt import run

if __name__ == "__main__":
    run()
