"""The programs' start: Ctrl-C while a program starts (its imports of numba, MuJoCo and
gymnasium, before any work) ends it at once with one line and exit status 130, not a traceback.

Importing this module installs the handler: ``scripts/<name>.py`` import it first, and the
installed commands start through it (``visuomotor-train`` is ``visuomotor_startup:train``, which
runs ``envs.cli.train.run``). It is a module of its own, outside ``envs``, because importing
``envs`` is most of the start-up. ``envs.cli.common.run`` makes Ctrl-C a KeyboardInterrupt
again once the program runs, which the programs handle (``train.py`` stops after the trial).
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
from collections.abc import Callable
from types import FrameType


def _interrupted(signum: int, frame: FrameType | None) -> None:
    name = os.path.basename(sys.argv[0])
    os.write(2, f"{name}: interrupted (Ctrl-C) during start-up; nothing was done\n".encode())
    os._exit(128 + signum)  # nothing to clean up yet; an exception could land in a C callback


signal.signal(signal.SIGINT, _interrupted)


def __getattr__(name: str) -> Callable[[], None]:
    """The entry point of the program ``envs.cli.<name>`` (an installed command)."""
    if name.startswith("_") or not name.isidentifier():
        raise AttributeError(name)

    def start() -> None:
        importlib.import_module(f"envs.cli.{name}").run()

    return start
