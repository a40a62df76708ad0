"""Reach-env speed: steps per second for every robot × sensing × control, against Gymnasium's
``Reacher-v5`` measured in the same run, plus the cost of one rendered stereo sensing, plus the
RL loop.

The program is :mod:`envs.cli.bench_envs` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.bench_envs import run

if __name__ == "__main__":
    run()
