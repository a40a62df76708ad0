"""Train the visuomotor SOM on a reach env, headless, with checkpoints and held-out evaluations.

The program is :mod:`envs.cli.train` (also installed as a console script).
"""

from envs.cli.train import run

if __name__ == "__main__":
    run()
