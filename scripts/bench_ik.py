"""Benchmark the exact baselines against the SOM: time per single query and batch throughput.

The program is :mod:`envs.cli.bench_ik` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.bench_ik import run

if __name__ == "__main__":
    run()
