"""Training with workers measured: trials per second, held-out errors, the learner's share.

The program is :mod:`envs.cli.bench_workers` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.bench_workers import run

if __name__ == "__main__":
    run()
