"""Off-screen rendering without a display: the GL back-end, started lazily, and a fast camera
renderer.

No GL library is loaded until a renderer is first needed: :func:`configure_gl_backend` (run by
``import envs``) lets mujoco be imported with ``MUJOCO_GL=disable`` and puts a lazy ``GLContext``
in its place, so exact-projection sensing works whatever ``MUJOCO_GL`` says and whether or not
a GL library works. The first renderer then starts the back-end the caller chose in
``MUJOCO_GL`` (or EGL, then OSMesa, whichever library is installed); a library that is missing
or broken raises :class:`RenderingUnavailableError` naming it and the fix.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import importlib
import os
import re
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

BACKENDS = ("egl", "osmesa")
#: The library each back-end loads (``lib<name>.so``).
LIBRARIES = {"egl": "EGL", "osmesa": "OSMesa"}
#: Geom groups of the scenes: 0 scene, 1 target, 2 robot, 3 collision, 4 effector marker.
GROUP_SCENE, GROUP_TARGET, GROUP_ROBOT, GROUP_COLLISION, GROUP_MARKER = range(5)
#: Geom groups of the whole visible scene, as people and the agents' cameras see it: the floor,
#: the target, the robot and the effector marker (MuJoCo's default options draw groups 0-2
#: only, which leaves the marker out).
VISIBLE_GROUPS = (GROUP_SCENE, GROUP_TARGET, GROUP_ROBOT, GROUP_MARKER)
_HELP = (
    "Off-screen rendering needs EGL or OSMesa. Set MUJOCO_GL=egl (Mesa's libEGL, with llvmpipe "
    "when there is no GPU) or MUJOCO_GL=osmesa after installing the Debian package libosmesa6 "
    "(apt-get install libosmesa6)."
)

if TYPE_CHECKING:
    import mujoco  # imported at run time only where used: envs picks the GL back-end first

#: A GL library in /proc/self/maps (loaded by anyone in this process, not only by this module).
_GL_MAPPED = re.compile(r"/lib(EGL|OSMesa|GLX|GL)[._][^/\n]*$", re.MULTILINE)


class RenderingUnavailableError(RuntimeError):
    """No off-screen OpenGL back-end could be started."""


def check_own_package() -> None:
    """ImportError naming the package if the ``envs`` imported in this process is not the one
    this module belongs to.

    A folder named ``envs`` beside a script (or earlier on ``sys.path``) is imported in place of
    this project's package; an editable install, or a package that extends its ``__path__``,
    then still finds this project's submodules under it, which would run without the GL set-up
    and the Gymnasium registration that this project's ``envs/__init__.py`` does.
    """
    parent = sys.modules.get("envs")
    if parent is None:
        return
    ours = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
    found = getattr(parent, "__file__", None)  # None: a namespace package, never this one
    where = os.path.dirname(os.path.realpath(found)) if found else ", ".join(parent.__path__)
    if where != ours:
        raise ImportError(
            f"the package 'envs' imported here is {where}, not this project's ({ours}): rename "
            "that folder or move your script out of its folder "
            "(Troubleshooting: docs/troubleshooting.md)"
        )


check_own_package()

#: Whether this process has started an OpenGL context, and whether its parent had (or had GL
#: libraries loaded) when it forked this process: EGL and OSMesa are not fork-safe, so a context
#: made after such a fork hangs.
_gl_started = False
_gl_started_before_fork = False
#: MUJOCO_GL as the caller set it when envs was imported (None: choose at the first render).
_requested: str | None = None
_backend: str | None = None  # the started back-end


def gl_libraries_loaded() -> bool:
    """Whether any GL library (libEGL, libOSMesa, libGL, libGLX) is mapped into this process."""
    try:
        with open("/proc/self/maps") as maps:
            return _GL_MAPPED.search(maps.read()) is not None
    except OSError:  # no /proc: only what this module started is known
        return False


def _after_fork_in_child() -> None:
    global _gl_started_before_fork
    _gl_started_before_fork = _gl_started_before_fork or _gl_started or gl_libraries_loaded()


os.register_at_fork(after_in_child=_after_fork_in_child)


def configure_gl_backend() -> str | None:
    """Import mujoco without loading a GL library, with a lazy ``GLContext``; returns the
    back-end the caller asked for in MUJOCO_GL (None: chosen at the first render).

    Run by ``import envs``. If mujoco was imported before with MUJOCO_GL set, the context it
    loaded is kept (unless it is mujoco's placeholder for a back-end that failed).
    """
    global _requested
    _requested = os.environ.get("MUJOCO_GL")
    if "mujoco" not in sys.modules:
        os.environ["MUJOCO_GL"] = "disable"
        try:
            import mujoco  # noqa: F401
        finally:
            if _requested is None:
                del os.environ["MUJOCO_GL"]
            else:
                os.environ["MUJOCO_GL"] = _requested
    from mujoco.rendering.classic import gl_context

    current = getattr(gl_context, "GLContext", None)
    # Replaced: none, mujoco's placeholder for a failed back-end, or its display default (GLFW)
    # chosen because MUJOCO_GL was unset when mujoco was imported before envs.
    if current is None or current.__module__ == gl_context.__name__ or _requested is None:
        _set_gl_context(_lazy_gl_context)
    return _requested


def _set_gl_context(context) -> None:
    """Make ``context`` the GLContext of mujoco's renderer and of its public names."""
    import mujoco
    from mujoco.rendering.classic import gl_context

    gl_context.GLContext = mujoco.GLContext = context
    if "mujoco.gl_context" in sys.modules:  # an older mujoco's module name, if it was imported
        # A module found by name is a plain ModuleType to the type checker.
        sys.modules["mujoco.gl_context"].GLContext = context  # type: ignore[attr-defined]


def _lazy_gl_context(max_width: int, max_height: int):
    """Start the back-end, then make a context of it (what mujoco's Renderer calls)."""
    start_gl_backend()
    from mujoco.rendering.classic import gl_context

    return gl_context.GLContext(max_width, max_height)


def _check_library(backend: str) -> None:
    """RenderingUnavailableError naming the library if ``backend``'s library is missing or does
    not load."""
    name = LIBRARIES[backend]
    found = ctypes.util.find_library(name)
    if found is None:
        raise RenderingUnavailableError(f"MUJOCO_GL={backend}: lib{name} was not found. {_HELP}")
    try:
        ctypes.CDLL(found)
    except OSError as exc:
        raise RenderingUnavailableError(
            f"MUJOCO_GL={backend}: lib{name} ({found}) does not load: {exc}. {_HELP}"
        ) from exc


def start_gl_backend() -> str:
    """Start the GL back-end (once per process) and return its name.

    Raises:
        RenderingUnavailableError: no back-end library found, or the chosen one missing or broken.
    """
    global _backend
    if _backend is not None:
        return _backend
    chosen = _requested
    if chosen is None:
        found = [b for b in BACKENDS if ctypes.util.find_library(LIBRARIES[b])]
        if not found:
            raise RenderingUnavailableError(f"neither libEGL nor libOSMesa was found. {_HELP}")
        chosen = found[0]
    if chosen in BACKENDS:
        _check_library(chosen)
        os.environ.setdefault("PYOPENGL_PLATFORM", chosen)
    os.environ["MUJOCO_GL"] = chosen
    from mujoco.rendering.classic import gl_context

    if gl_context.GLContext is _lazy_gl_context:
        try:
            if chosen in BACKENDS:
                context = importlib.import_module(f"mujoco.{chosen}").GLContext
            else:  # glfw, glx, ...: mujoco's own choice for this MUJOCO_GL
                context = getattr(importlib.reload(gl_context), "GLContext", None)
        except Exception as exc:  # PyOpenGL raises many different types for a bad library
            raise RenderingUnavailableError(
                f"could not start MUJOCO_GL={chosen}: {exc!r}. {_HELP}"
            ) from exc
        if context is None:
            raise RenderingUnavailableError(f"MUJOCO_GL={chosen} disables rendering. {_HELP}")
        _set_gl_context(context)
    _backend = chosen
    return chosen


def check_same_process(started_in: int) -> None:
    """RenderingUnavailableError unless this is process ``started_in``, the one that made a
    renderer's GL context: a context inherited through a fork hangs when it is used."""
    if os.getpid() != started_in:
        raise RenderingUnavailableError(
            f"this env's renderer started OpenGL in process {started_in}, and this is process "
            f"{os.getpid()}, forked from it: EGL and OSMesa hang on an inherited context. Make "
            "the env in the process that uses it; start worker processes with 'forkserver' or "
            "'spawn', e.g. gymnasium.vector.AsyncVectorEnv(env_fns, context='forkserver')."
        )


def check_gl_allowed() -> None:
    """Raise in a process forked after its parent had started OpenGL; else start the back-end."""
    if _gl_started_before_fork:
        raise RenderingUnavailableError(
            "this process was forked after its parent had started OpenGL (or loaded a GL "
            "library), and EGL and "
            "OSMesa hang when started again after a fork. Start worker processes with "
            "'forkserver' or 'spawn', e.g. gymnasium.vector.AsyncVectorEnv(env_fns, "
            "context='forkserver'), or create them before anything renders."
        )
    start_gl_backend()


def gl_start_error(exc: Exception) -> RenderingUnavailableError:
    """The error to raise when an OpenGL context could not be made."""
    backend = os.environ.get("MUJOCO_GL", "unset")
    return RenderingUnavailableError(f"could not start MUJOCO_GL={backend}: {exc}. {_HELP}")


def mark_gl_started() -> None:
    """Record that this process has an OpenGL context (see :func:`check_gl_allowed`)."""
    global _gl_started
    _gl_started = True


@contextmanager
def gl_current(gl) -> Iterator[None]:
    """Make the GL context ``gl`` current for the block, then restore whichever context was
    current before (that of another renderer, or none).

    A context without ``as_current`` (mujoco before 3.3, display back-ends) stays current after
    the block; every renderer here makes its own context current before it draws, so that is
    safe too.
    """
    as_current = getattr(gl, "as_current", None)
    if as_current is None:
        gl.make_current()
        yield
    else:
        with as_current():
            yield


def free_gl(gl, mjr_context) -> None:
    """Free an ``MjrContext`` and then the GL context ``gl`` it was made in, leaving the current
    context of the process as it was.

    ``mjr_freeContext`` deletes its framebuffers, textures and lists by name in whatever context
    is current, and every context numbers its objects alike: freed under another renderer's
    context it would delete that renderer's framebuffer, and that renderer would then draw
    nothing. Freeing the GL context first (as its own finaliser does when garbage collection
    drops it) leaves the same wrong context current for the ``MjrContext``.
    """
    with gl_current(gl):
        mjr_context.free()
    gl.free()


#: Render flags the sensing cameras turn off (flat colours suffice; software GL is faster).
SENSING_OFF_FLAGS = ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX")


class CameraRenderer:
    """Renders named cameras of one model to RGB arrays, created lazily (so envs pickle).

    ``fast=True`` turns off shadows, reflections, the skybox, textures and multisampling: the
    sensing cameras only need flat colours, and software rendering is faster without them
    (measured in docs/sensing.md, "Rendering back-ends").
    """

    def __init__(self, model: mujoco.MjModel, height: int, width: int, fast: bool = True) -> None:
        if width > model.vis.global_.offwidth or height > model.vis.global_.offheight:
            raise ValueError(
                f"{width}x{height} exceeds the model's off-screen buffer "
                f"{model.vis.global_.offwidth}x{model.vis.global_.offheight}; raise "
                "<visual><global offwidth offheight> in the scene"
            )
        self.model, self.height, self.width, self.fast = model, height, width, fast
        self._renderer = None
        self._pid = 0  # the process that made _renderer's GL context
        self._options: dict = {}  # geom groups -> mujoco.MjvOption

    def _get(self):
        if self._renderer is not None:
            check_same_process(self._pid)
        else:
            import mujoco

            check_gl_allowed()
            samples = self.model.vis.quality.offsamples
            if self.fast:  # the sample count is read when the GL context is made
                self.model.vis.quality.offsamples = 0
            try:
                self._renderer = mujoco.Renderer(self.model, self.height, self.width)
            except Exception as exc:  # the GL libraries raise many different types
                raise gl_start_error(exc) from exc
            finally:
                self.model.vis.quality.offsamples = samples
            mark_gl_started()
            self._pid = os.getpid()
            if self.fast:
                flags = self._renderer.scene.flags
                for flag in SENSING_OFF_FLAGS:
                    flags[getattr(mujoco.mjtRndFlag, flag)] = 0
        return self._renderer

    def render(
        self, data: mujoco.MjData, camera: str, groups: Sequence[int] | None = None
    ) -> np.ndarray:
        """RGB image (height, width, 3) uint8 of ``camera``; ``groups`` = geom groups to draw."""
        import mujoco

        renderer = self._get()
        key = None if groups is None else tuple(groups)
        option = self._options.get(key)
        if option is None:  # built once per set of groups: this is on every sensing step
            option = mujoco.MjvOption()
            if self.fast:
                option.flags[mujoco.mjtVisFlag.mjVIS_TEXTURE] = 0
            if key is not None:
                option.geomgroup[:] = 0
                for g in key:
                    option.geomgroup[g] = 1
            self._options[key] = option
        renderer.update_scene(data, camera=camera, scene_option=option)
        return renderer.render()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_renderer": None, "_options": {}}


def render_camera(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    camera: str,
    height: int = 240,
    width: int = 320,
    groups: Sequence[int] = VISIBLE_GROUPS,
) -> np.ndarray:
    """One RGB frame (height, width, 3) uint8 of a named camera with the fast settings, showing
    ``groups`` (default: everything a person should see, the green marker included)."""
    renderer = CameraRenderer(model, height, width)
    try:
        return renderer.render(data, camera, groups)
    finally:
        renderer.close()
