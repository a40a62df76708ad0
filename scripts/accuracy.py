"""Kinematic accuracy of an arm at one pose: Němeček's linear error model, reverse-mode derivatives.

The program is :mod:`envs.cli.kinematic_accuracy` (also installed as a console script).
"""

from envs.cli.kinematic_accuracy import run

if __name__ == "__main__":
    run()
