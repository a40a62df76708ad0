"""Imported first by every program here: Ctrl-C while the program starts (its imports of numba,
MuJoCo, gymnasium, before any work) ends it at once with one line and exit status 130, not a
traceback. ``envs.cli.common.run`` then makes Ctrl-C a KeyboardInterrupt again, which the
programs handle (``train.py`` stops after the current trial)."""

import os
import signal
import sys
from types import FrameType


def _interrupted(signum: int, frame: FrameType | None) -> None:
    name = os.path.basename(sys.argv[0])
    os.write(2, f"{name}: interrupted (Ctrl-C) during start-up; nothing was done\n".encode())
    os._exit(128 + signum)  # nothing to clean up yet; an exception could land in a C callback


signal.signal(signal.SIGINT, _interrupted)
