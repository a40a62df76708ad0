"""Build the RIACS data set of Jorgensen (1990): build3dpts, a seeded buildtset split, the plots.

The program is :mod:`envs.cli.riacs_dataset` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.riacs_dataset import run

if __name__ == "__main__":
    run()
