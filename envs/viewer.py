"""``render_mode="human"``: MuJoCo's own viewer (``mujoco.viewer.launch_passive``) on an env.

The viewer opens a GLFW window and draws it from its own thread; the env calls :meth:`show`
after every reset and move. It needs a display (an X server, e.g. a desktop or ``xvfb-run``)
but not ``MUJOCO_GL=glfw``: the window's OpenGL context is GLFW's, independent of the off-screen
back-end (EGL or OSMesa) the env's cameras render with, so ``MUJOCO_GL=egl`` (this project's
default) and the human viewer work together in one process. Without a display GLFW cannot start,
and MuJoCo's viewer would then end the whole process from its thread; :func:`open_viewer` checks
first and raises :class:`DisplayUnavailableError` instead.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
import threading
import time

from envs.sensing.rendering import GROUP_MARKER, GROUP_ROBOT, GROUP_SCENE, GROUP_TARGET

#: Geom groups the window shows: the scene, the target, the robot and the effector marker.
SHOWN_GROUPS = (GROUP_SCENE, GROUP_TARGET, GROUP_ROBOT, GROUP_MARKER)
N_GEOM_GROUPS = 6  # mjNGROUP
CLOSE_TIMEOUT = 10.0  # s to wait for the window's thread to end
_HELP = (
    "render_mode='human' opens a window with MuJoCo's viewer (GLFW) and needs a display: run it "
    "on a desktop, under a virtual X server (xvfb-run -a python ..., Debian package xvfb), or use "
    "render_mode='rgb_array' for frames without a window"
)


class DisplayUnavailableError(RuntimeError):
    """No display to open the human viewer's window on."""


def open_viewer(model, data):
    """MuJoCo's passive viewer on ``model``/``data`` showing SHOWN_GROUPS, without the side
    panels, and the threads it started; raises :class:`DisplayUnavailableError` without a
    display (checked here: MuJoCo's viewer thread would end the process)."""
    if sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise DisplayUnavailableError(f"DISPLAY is not set. {_HELP}")
    if not _display_opens():
        display = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        raise DisplayUnavailableError(f"cannot open display {display!r}. {_HELP}")
    import mujoco.viewer

    before = set(threading.enumerate())
    handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False)
    with handle.lock():
        for group in range(N_GEOM_GROUPS):
            handle.opt.geomgroup[group] = group in SHOWN_GROUPS
    return handle, [t for t in threading.enumerate() if t not in before]


def _display_opens() -> bool:
    """Whether the X display of DISPLAY accepts a connection (Xlib's XOpenDisplay); True where
    that cannot be checked (no libX11: Wayland, macOS, Windows), leaving it to GLFW."""
    if not os.environ.get("DISPLAY"):
        return True
    name = ctypes.util.find_library("X11")
    if name is None:
        return True
    xlib = ctypes.CDLL(name)
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    display = xlib.XOpenDisplay(os.environ["DISPLAY"].encode())
    if not display:
        return False
    xlib.XCloseDisplay(display)
    return True


class HumanViewer:
    """The window of one env, opened at the first :meth:`show`, at most ``fps`` frames a second
    (one frame per move, so that a person can follow the moves)."""

    def __init__(self, fps: float) -> None:
        self.fps = fps
        self.handle = None
        self._threads: list[threading.Thread] = []  # the viewer's, joined at close
        self._last = 0.0  # time.monotonic() of the last frame, s

    def show(self, model, data) -> None:
        if self.handle is None:
            self.handle, self._threads = open_viewer(model, data)
        if not self.handle.is_running():  # the user closed the window
            return
        wait = self._last + 1.0 / self.fps - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        self.handle.sync()
        self._last = time.monotonic()

    def close(self) -> None:
        if self.handle is not None:
            self.handle.close()
            # The window's thread must end before the interpreter exits: GLFW's exit handler
            # would otherwise wait for it forever.
            for thread in self._threads:
                thread.join(CLOSE_TIMEOUT)
            self.handle, self._threads = None, []
