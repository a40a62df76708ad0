"""Train NATEnet on PumaTrack-v0 and compare its path tracking with the exact inverse Jacobian,
a fixed-grid net of the same size (no allocation) and the untrained net.

The program is :mod:`envs.cli.train_natenet` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.train_natenet import run

if __name__ == "__main__":
    run()
