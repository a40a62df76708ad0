"""Error against training trials per leaf of the hierarchical map on the idealised grasp task.

The program is :mod:`envs.cli.grasp_learning` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.grasp_learning import run

if __name__ == "__main__":
    run()
