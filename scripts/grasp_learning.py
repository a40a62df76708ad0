"""Error against training trials per leaf of the hierarchical map on the idealised grasp task.

The program is :mod:`envs.cli.grasp_learning` (also installed as a console script).
"""

from envs.cli.grasp_learning import run

if __name__ == "__main__":
    run()
