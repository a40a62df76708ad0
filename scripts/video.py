"""Rendered evaluation video: a controller's coarse and fine moves on a reach env, as mp4.

The program is :mod:`envs.cli.video` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.video import run

if __name__ == "__main__":
    run()
