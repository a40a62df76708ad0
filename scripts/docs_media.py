"""The documentation's animations: one small looping GIF per environment, in docs/assets/.

The program is :mod:`envs.cli.docs_media` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.docs_media import run

if __name__ == "__main__":
    run()
