"""Run a grid of training runs on Ray (local by default) and collect one results table.

The program is :mod:`envs.cli.sweep` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.sweep import run

if __name__ == "__main__":
    run()
