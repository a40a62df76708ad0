"""Speed of the visuomotor SOM, with MiniSom measured in the same run as the peer.

The program is :mod:`envs.cli.bench_som` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.bench_som import run

if __name__ == "__main__":
    run()
