"""How well each arm's cameras frame its workspace, sensing and pixel cameras.

The program is :mod:`envs.cli.framing` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.framing import run

if __name__ == "__main__":
    run()
