"""Run a grid of training runs on Ray (local by default) and collect one results table.

The program is :mod:`envs.cli.sweep` (also installed as a console script).
"""

from envs.cli.sweep import run

if __name__ == "__main__":
    run()
