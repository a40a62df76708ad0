"""The documentation's animations: one small looping GIF per environment, in docs/assets/.

The program is :mod:`envs.cli.docs_media` (also installed as a console script).
"""

from envs.cli.docs_media import run

if __name__ == "__main__":
    run()
