"""Query time of NATEnet beside the exact inverse Jacobian, measured in the same run.

The program is :mod:`envs.cli.bench_natenet` (also installed as a console script).
"""

from envs.cli.bench_natenet import run

if __name__ == "__main__":
    run()
