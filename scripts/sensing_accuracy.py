"""Rendered marker sensing (whole images and foveated) against the exact projection, by the
fraction of the marker that the robot hides.

The program is :mod:`envs.cli.sensing_accuracy` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.sensing_accuracy import run

if __name__ == "__main__":
    run()
