"""Benchmarks that print numbers and ratios against a peer measured in the same run.

The program is :mod:`envs.cli.bench` (also installed as a console script).
"""

from envs.cli.bench import run

if __name__ == "__main__":
    run()
