"""Train the visuomotor SOM on a reach env, headless, with checkpoints and held-out evaluations.

The program is :mod:`envs.cli.train` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.train import run

if __name__ == "__main__":
    run()
