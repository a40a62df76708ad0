"""``render_mode="human"``: MuJoCo's own viewer (``mujoco.viewer.launch_passive``) on an env.

The viewer opens a GLFW window and draws it from its own thread; the env calls :meth:`show`
after every reset and move. It needs a display (an X server, e.g. a desktop or ``xvfb-run``)
but not ``MUJOCO_GL=glfw``: the window's OpenGL context is GLFW's, independent of the off-screen
back-end (EGL or OSMesa) the env's cameras render with, so ``MUJOCO_GL=egl`` (this project's
default) and the human viewer work together in one process. Without a display GLFW cannot start,
and MuJoCo's viewer would then end the whole process from its thread; :func:`open_viewer` checks
first and raises :class:`DisplayUnavailableError` instead.

Opening the window (GLFW, a GL context, MuJoCo's fonts, shadow maps and offscreen buffers) and
the env's first reset (the numba kernels load, the off-screen back-end starts) each take a
while: :meth:`HumanViewer.start` opens the window in a thread while the env gets ready, and the
first :meth:`HumanViewer.show` waits for it. The window opens on a free
camera framing the whole arm and its workspace (:func:`frame_scene`), not on MuJoCo's default.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
import threading
import time

from envs.sensing.rendering import VISIBLE_GROUPS

N_GEOM_GROUPS = 6  # mjNGROUP
CLOSE_TIMEOUT = 10.0  # s to wait for the window's thread to end
#: Free-camera distance in units of the scene's ``<statistic extent>`` (the arm with its
#: workspace fills about two thirds of the window).
VIEW_DISTANCE = 1.45
#: Shadow map side (pixels) of the window: the scenes' larger maps are slow to set up in
#: software GL, for no visible gain at window size.
WINDOW_SHADOW_SIZE = 1024
_HELP = (
    "render_mode='human' opens a window with MuJoCo's viewer (GLFW) and needs a display: run it "
    "on a desktop, under a virtual X server (xvfb-run -a python ..., Debian package xvfb), or use "
    "render_mode='rgb_array' for frames without a window"
)


class DisplayUnavailableError(RuntimeError):
    """No display to open the human viewer's window on."""


def open_viewer(model, data):
    """MuJoCo's passive viewer on ``model``/``data`` showing VISIBLE_GROUPS, without the side
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
            handle.opt.geomgroup[group] = group in VISIBLE_GROUPS
        frame_scene(handle.cam, model)
    return handle, [t for t in threading.enumerate() if t not in before]


def frame_scene(camera, model) -> None:
    """Point a ``mujoco.MjvCamera`` as a free camera at the scene's ``<statistic center>`` (the
    scenes set it between the arm and its workspace) from ``VIEW_DISTANCE`` times its ``extent``,
    at the scene's ``<global azimuth elevation>``."""
    import mujoco

    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.fixedcamid = -1
    camera.lookat[:] = model.stat.center
    camera.distance = VIEW_DISTANCE * float(model.stat.extent)
    camera.azimuth = float(model.vis.global_.azimuth)
    camera.elevation = float(model.vis.global_.elevation)


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
    """The window of one env, at most ``fps`` frames a second (one frame per move, so that a
    person can follow the moves).

    :meth:`start` begins to open the window in a thread; the first :meth:`show` waits for it
    (and raises what opening raised, e.g. :class:`DisplayUnavailableError`).
    """

    def __init__(self, fps: float) -> None:
        self.fps = fps
        self.handle = None
        self._threads: list[threading.Thread] = []  # the viewer's, joined at close
        self._opener: threading.Thread | None = None
        self._error: BaseException | None = None  # raised by the opener
        self._last = 0.0  # time.monotonic() of the last frame, s

    def start(self, model, data) -> None:
        """Begin opening the window on ``model``/``data`` (once)."""
        if self._opener is not None or self.handle is not None:
            return
        model.vis.quality.shadowsize = min(model.vis.quality.shadowsize, WINDOW_SHADOW_SIZE)

        def open_window() -> None:
            try:
                self.handle, self._threads = open_viewer(model, data)
            except BaseException as exc:  # handed to the first show()
                self._error = exc

        self._opener = threading.Thread(target=open_window, name="open-viewer", daemon=True)
        self._opener.start()

    def show(self, model, data) -> None:
        if self.handle is None:
            self.start(model, data)
            self._opener.join()
            if self._error is not None:
                error, self._error, self._opener = self._error, None, None
                raise error
        if not self.handle.is_running():  # the user closed the window
            return
        wait = self._last + 1.0 / self.fps - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        self.handle.sync()
        self._last = time.monotonic()

    def close(self) -> None:
        if self._opener is not None:
            self._opener.join()
            self._opener = None
        if self.handle is not None:
            self.handle.close()
            # The window's thread must end before the interpreter exits: GLFW's exit handler
            # would otherwise wait for it forever.
            for thread in self._threads:
                thread.join(CLOSE_TIMEOUT)
            self.handle, self._threads = None, []
