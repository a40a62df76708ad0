"""A realistic training trial's cost: renders, views, physics steps and ms per part per trial.

The program is :mod:`envs.cli.bench_trials` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.bench_trials import run

if __name__ == "__main__":
    run()
