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
first :meth:`HumanViewer.show` waits for it.

What the window shows: at the first frame a free camera frames the arm, the robot's target
workspace and the target (:func:`frame_scene`); the target and marker spheres are drawn at least
a few pixels large, a target that a marker touches as a see-through shell (the frames for
people's :func:`envs.sensing.drawn_spheres.spheres_drawn`, applied while the frame is handed to the
viewer); and no shadows: the scenes' directional light casts them from a map that covers only
``stat.extent·map.shadowclip`` round the light, and the floor beyond it speckles on Mesa's
llvmpipe. The sensing cameras draw the model as it is, without shadows, as before.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
import threading
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from envs.sensing.drawn_spheres import spheres_drawn
from envs.sensing.rendering import VISIBLE_GROUPS

if TYPE_CHECKING:
    import mujoco

    from models.workspace import Workspace

N_GEOM_GROUPS = 6  # mjNGROUP
CLOSE_TIMEOUT = 10.0  # s to wait for the window's thread to end
#: The framed points (:func:`frame_points`) reach out to this fraction of the window's half-height
#: from its centre (and as far sideways: a window at least as wide as high).
FRAME_FILL = 0.85
#: Points of the target workspace that the window frames (its bounding box's corners can lie
#: far from every target: a reachable workspace is not a box), and their generator's seed.
WORKSPACE_POINTS, WORKSPACE_SEED = 512, 0
FRAME_ITERATIONS = 4  # re-centring rounds of frame_scene (perspective moves the points' centre)
#: The target and marker spheres are drawn with a radius of at least this fraction of the
#: window's half-height at the framed distance.
SPHERE_FRACTION = 0.035
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
    # The window's GL context is made (and its shadow map sized) before launch_passive returns.
    shadowsize = model.vis.quality.shadowsize
    model.vis.quality.shadowsize = min(shadowsize, WINDOW_SHADOW_SIZE)
    try:
        handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False)
    finally:
        model.vis.quality.shadowsize = shadowsize
    with handle.lock():
        for group in range(N_GEOM_GROUPS):
            handle.opt.geomgroup[group] = group in VISIBLE_GROUPS
        handle.user_scn.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0  # the viewer takes them at sync
    return handle, [t for t in threading.enumerate() if t not in before]


def camera_axes(azimuth: float, elevation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A MuJoCo free camera's forward, up and right unit vectors (3,) each for its azimuth and
    elevation (degrees), as ``mjv_updateScene`` sets them."""
    az, el = np.radians(azimuth), np.radians(elevation)
    forward = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    up = np.array([-np.sin(el) * np.cos(az), -np.sin(el) * np.sin(az), np.cos(el)])
    return forward, up, np.cross(forward, up)


def frame_points(model: mujoco.MjModel, data: mujoco.MjData, workspace: Workspace) -> np.ndarray:
    """(N, 3) world points (m) a person should see: WORKSPACE_POINTS points of the robot's target
    workspace (drawn with a generator of their own: the env's draws are untouched) and, for
    every drawn geom but the floor (arm, markers, targets), its centre ± its bounding radius
    along each world axis."""
    import mujoco

    targets = workspace.sample(np.random.default_rng(WORKSPACE_SEED), WORKSPACE_POINTS)  # (W, 3)
    drawn = np.isin(model.geom_group, VISIBLE_GROUPS) & (
        model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE
    )
    centres, radii = data.geom_xpos[drawn], model.geom_rbound[drawn]  # (G, 3), (G,)
    offsets = np.concatenate([np.eye(3), -np.eye(3)])  # (6, 3)
    bounds = centres[:, None] + radii[:, None, None] * offsets  # (G, 6, 3)
    return np.concatenate([targets, bounds.reshape(-1, 3)])


def frame_scene(camera: mujoco.MjvCamera, model: mujoco.MjModel, points: np.ndarray) -> None:
    """Point ``camera`` as a free camera, at the scene's ``<global azimuth elevation>``, so that
    ``points`` (N, 3) m fill the window to FRAME_FILL of its half-height about its centre, seen
    through the scene's vertical field of view (``<global fovy>``).

    A point at (x, y) right and up of the look-at and z behind it, seen from distance D, shows
    at x / (D + z) of the window's half-height per ``tan(fovy / 2)``: D is the least with every
    point inside FRAME_FILL; the look-at then moves to the centre of the points' image.
    """
    import mujoco

    azimuth, elevation = float(model.vis.global_.azimuth), float(model.vis.global_.elevation)
    forward, up, right = camera_axes(azimuth, elevation)
    reach = FRAME_FILL * np.tan(np.radians(model.vis.global_.fovy) / 2)
    lookat = (points.min(axis=0) + points.max(axis=0)) / 2
    for _ in range(FRAME_ITERATIONS):
        offset = points - lookat  # (N, 3)
        x, y, z = offset @ right, offset @ up, offset @ forward  # (N,) each, m
        distance = float(np.max(np.maximum(np.abs(x), np.abs(y)) / reach - z))
        u, v = x / (distance + z), y / (distance + z)  # (N,) image offsets per unit depth
        lookat = lookat + distance * (
            (u.max() + u.min()) / 2 * right + (v.max() + v.min()) / 2 * up
        )
    offset = points - lookat
    x, y, z = offset @ right, offset @ up, offset @ forward
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.fixedcamid = -1
    camera.lookat[:] = lookat
    camera.distance = float(np.max(np.maximum(np.abs(x), np.abs(y)) / reach - z))
    camera.azimuth, camera.elevation = azimuth, elevation


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
    (and raises what opening raised, e.g. :class:`DisplayUnavailableError`) and frames the
    camera on the arm, ``workspace`` and the target (:func:`frame_scene`).

    Args:
        fps: frames a second at most.
        workspace: the robot's target workspace (world, m).
        targets, markers: geom ids of the target spheres and the arm's marker spheres.
    """

    def __init__(
        self, fps: float, workspace: Workspace, targets: np.ndarray, markers: np.ndarray
    ) -> None:
        self.fps = fps
        self.workspace, self.targets, self.markers = workspace, targets, markers
        self.handle: Any = None  # mujoco.viewer.Handle once the window is open
        self._threads: list[threading.Thread] = []  # the viewer's, joined at close
        self._opener: threading.Thread | None = None
        self._error: BaseException | None = None  # raised by the opener
        self._last = 0.0  # time.monotonic() of the last frame, s
        self._framed = False  # the camera was framed (at the first frame)

    def start(self, model, data) -> None:
        """Begin opening the window on ``model``/``data`` (once)."""
        if self._opener is not None or self.handle is not None:
            return

        def open_window() -> None:
            try:
                self.handle, self._threads = open_viewer(model, data)
            except BaseException as exc:  # handed to the first show()
                self._error = exc

        self._opener = threading.Thread(target=open_window, name="open-viewer", daemon=True)
        self._opener.start()

    def show(self, model, data) -> None:
        """Hand the scene of ``data`` to the window (the first time: open it, frame it)."""
        if self.handle is None:
            self.start(model, data)
            assert self._opener is not None
            self._opener.join()
            if self._error is not None:
                error, self._error, self._opener = self._error, None, None
                raise error
        if not self.handle.is_running():  # the user closed the window
            return
        if not self._framed:
            with self.handle.lock():
                frame_scene(self.handle.cam, model, frame_points(model, data, self.workspace))
            self._framed = True
        wait = self._last + 1.0 / self.fps - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        camera = self.handle.cam
        radius = SPHERE_FRACTION * camera.distance * np.tan(np.radians(model.vis.global_.fovy) / 2)
        # sync() builds the window's scene from the model here, in this thread: the spheres are
        # drawn so for the window only, and are as they were when sync() returns.
        with spheres_drawn(model, data, self.targets, self.markers, radius):
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
            self.handle, self._threads, self._framed = None, [], False
