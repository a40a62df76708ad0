"""Kinematic accuracy of an arm at one pose: Němeček's linear error model, reverse-mode derivatives.

The program is :mod:`envs.cli.kinematic_accuracy` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.kinematic_accuracy import run

if __name__ == "__main__":
    run()
