"""Query time of NATEnet beside the exact inverse Jacobian, measured in the same run.

The program is :mod:`envs.cli.bench_natenet` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.bench_natenet import run

if __name__ == "__main__":
    run()
