"""Off-screen rendering without a display: back-end choice and a fast camera renderer.

``MUJOCO_GL`` is read by mujoco when it is imported, so :func:`configure_gl_backend` runs when
``envs`` is imported, before mujoco: it keeps a back-end the caller chose and otherwise picks EGL,
then OSMesa, whichever library is installed.
"""

from __future__ import annotations

import ctypes.util
import os
import sys
from collections.abc import Sequence

import numpy as np

BACKENDS = ("egl", "osmesa")
#: Geom groups of the scenes: 0 scene, 1 target, 2 robot, 3 collision, 4 effector marker.
GROUP_SCENE, GROUP_TARGET, GROUP_ROBOT, GROUP_COLLISION, GROUP_MARKER = range(5)
_HELP = (
    "Off-screen rendering needs EGL or OSMesa. Set MUJOCO_GL=egl (Mesa's libEGL, with llvmpipe "
    "when there is no GPU) or MUJOCO_GL=osmesa after installing the Debian package libosmesa6 "
    "(apt-get install libosmesa6)."
)


class RenderingUnavailableError(RuntimeError):
    """No off-screen OpenGL back-end could be started."""


#: Whether this process has started an OpenGL context, and whether its parent had when it forked
#: this process: EGL and OSMesa are not fork-safe, so a context made after such a fork hangs.
_gl_started = False
_gl_started_before_fork = False


def _after_fork_in_child() -> None:
    global _gl_started_before_fork
    _gl_started_before_fork = _gl_started_before_fork or _gl_started


os.register_at_fork(after_in_child=_after_fork_in_child)


def configure_gl_backend() -> str:
    """Choose MUJOCO_GL (and PyOpenGL's platform) before mujoco is imported; return it."""
    chosen = os.environ.get("MUJOCO_GL")
    if chosen is None:
        libraries = {"egl": "EGL", "osmesa": "OSMesa"}
        found = [b for b in BACKENDS if ctypes.util.find_library(libraries[b])]
        if not found:
            raise RenderingUnavailableError(f"neither libEGL nor libOSMesa was found. {_HELP}")
        chosen = found[0]
        if "mujoco" in sys.modules:
            # Too late to choose: mujoco already picked its default. Say so rather than guess.
            raise RenderingUnavailableError(
                f"mujoco was imported before envs with MUJOCO_GL unset. Import envs first or set "
                f"MUJOCO_GL={chosen} in the environment. {_HELP}"
            )
        os.environ["MUJOCO_GL"] = chosen
    if chosen in BACKENDS:
        os.environ.setdefault("PYOPENGL_PLATFORM", chosen)
    return chosen


class CameraRenderer:
    """Renders named cameras of one model to RGB arrays, created lazily (so envs pickle).

    ``fast=True`` turns off shadows, reflections, the skybox, textures and multisampling: the
    sensing cameras only need flat colours, and software rendering is about 2.5 times faster
    without them (llvmpipe, 320×240: 12 ms -> 4.7 ms a frame).
    """

    def __init__(self, model, height: int, width: int, fast: bool = True) -> None:
        if width > model.vis.global_.offwidth or height > model.vis.global_.offheight:
            raise ValueError(
                f"{width}x{height} exceeds the model's off-screen buffer "
                f"{model.vis.global_.offwidth}x{model.vis.global_.offheight}; raise "
                "<visual><global offwidth offheight> in the scene"
            )
        self.model, self.height, self.width, self.fast = model, height, width, fast
        self._renderer = None
        self._options: dict = {}  # geom groups -> mujoco.MjvOption

    def _get(self):
        global _gl_started
        if self._renderer is None:
            import mujoco

            if _gl_started_before_fork:
                raise RenderingUnavailableError(
                    "this process was forked after its parent had started OpenGL, and EGL and "
                    "OSMesa hang when started again after a fork. Start worker processes with "
                    "'forkserver' or 'spawn', e.g. gymnasium.vector.AsyncVectorEnv(env_fns, "
                    "context='forkserver'), or create them before anything renders."
                )

            samples = self.model.vis.quality.offsamples
            if self.fast:  # the sample count is read when the GL context is made
                self.model.vis.quality.offsamples = 0
            try:
                self._renderer = mujoco.Renderer(self.model, self.height, self.width)
            except Exception as exc:  # the GL libraries raise many different types
                backend = os.environ.get("MUJOCO_GL", "unset")
                raise RenderingUnavailableError(
                    f"could not start MUJOCO_GL={backend}: {exc}. {_HELP}"
                ) from exc
            finally:
                self.model.vis.quality.offsamples = samples
            _gl_started = True
            if self.fast:
                flags = self._renderer.scene.flags
                for flag in ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX"):
                    flags[getattr(mujoco.mjtRndFlag, flag)] = 0
        return self._renderer

    def render(self, data, camera: str, groups: Sequence[int] | None = None) -> np.ndarray:
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


def render_camera(model, data, camera: str, height: int = 240, width: int = 320) -> np.ndarray:
    """One RGB frame of a named camera with the fast settings."""
    renderer = CameraRenderer(model, height, width)
    try:
        return renderer.render(data, camera)
    finally:
        renderer.close()
