"""Write a Menagerie-style robot folder for an arm given by its DH table.

The program is :mod:`envs.cli.make_arm` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.make_arm import run

if __name__ == "__main__":
    run()
