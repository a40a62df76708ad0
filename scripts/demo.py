"""The main job, end to end and headless: train the visuomotor SOM on both arms, evaluate it
with exact projection and kinematic moves and with rendered (foveated) cameras and servo moves,
and write plots, a video and camera images.

The program is :mod:`envs.cli.demo` (also installed as a console script).
"""

import visuomotor_startup  # noqa: F401  (first: Ctrl-C while starting is one line, exit 130)

# isort: split

from envs.cli.demo import run

if __name__ == "__main__":
    run()
