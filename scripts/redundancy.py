"""The redundancy of a map trained on a 7-joint arm: the swivel angle over the lattice, its jumps,
the held-out commands against the joint ranges.

The program is :mod:`envs.cli.redundancy` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.redundancy import run

if __name__ == "__main__":
    run()
