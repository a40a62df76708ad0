"""Evaluate controllers on fresh held-out targets: a table of errors after each move, and plots.

The program is :mod:`envs.cli.evaluate` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.evaluate import run

if __name__ == "__main__":
    run()
