"""Benchmarks that print numbers and ratios against a peer measured in the same run.

The program is :mod:`envs.cli.bench` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.bench import run

if __name__ == "__main__":
    run()
