"""Several camera views in one off-screen buffer: one render per view, one read-back for all.

Each :class:`View` is a camera drawn into its own viewport, either its whole image or a *window*:
an axis-aligned part of the camera's image drawn at a higher pixel density, as an off-centre
frustum (the near-plane rectangle of that part). Colour and depth come back in one
``mjr_readPixels``; depth is metric (m along the optical axis), used to tell which side of an edge
is nearer the camera.
"""

from __future__ import annotations

import math
import os
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np

from envs.sensing.rendering import (
    SENSING_OFF_FLAGS,
    check_gl_allowed,
    check_same_process,
    free_gl,
    gl_start_error,
    mark_gl_started,
)

if TYPE_CHECKING:
    import mujoco  # imported at run time only where used: envs picks the GL back-end first

#: Slices and stacks of the built-in meshes (spheres, capsules, cylinders): 10° facets keep a
#: sphere's outline within 1 - cos 5° = 0.4 % of its radius of a circle. MuJoCo's default
#: 28 × 16 (up to 1.9 %) misplaces a mostly hidden marker (tests/test_occlusion.py); finer
#: meshes cost drawing time on every cylinder and capsule of the robot (docs/decisions.md).
SPHERE_SLICES = 36
SPHERE_STACKS = 18
#: mjtGeom values of the capsule and the cylinder (bounded by capsules, see _bounding_capsules).
mjGEOM_CAPSULE, mjGEOM_CYLINDER = 3, 5
#: mjtGeom value of the plane.
mjGEOM_PLANE = 0
#: Relative tolerance on equal horizontal and vertical focal lengths (float32 model values).
SQUARE_PIXEL_TOL = 1e-5


@dataclass(frozen=True)
class Window:
    """A part of a camera's base image drawn at ``density`` pixels per base pixel.

    ``left``, ``top`` are the window's left and top *edges* in base pixel coordinates (the
    centre of base pixel (row i, column j) is (u, v) = (j, i), its edges at ±0.5); ``width``,
    ``height`` its size in window pixels. Window pixel (i, j) has its centre at base
    (left + (j + 0.5) / density, top + (i + 0.5) / density).

    A window draws only the geoms that can reach into it: those whose bounding capsule (a
    link's own, or a bounding sphere) meets its frustum, nearer than ``depth`` (m along the
    optical axis). Sensing a marker at most that deep gives the same result: a geom wholly
    behind it can neither hide it nor change its outline (an edge against anything farther
    counts as the sphere's own edge either way).
    """

    left: float
    top: float
    width: int
    height: int
    density: float = 1.0
    depth: float = math.inf

    @classmethod
    def full(cls, height: int, width: int) -> Window:
        """The whole base image at its own density."""
        return cls(-0.5, -0.5, width, height, 1.0)

    def on_image_border(self, height: int, width: int) -> tuple[bool, bool, bool, bool]:
        """Which of the window's sides (left, top, right, bottom) lie on the border of the base
        image of ``height`` × ``width`` px (a blob that reaches them is cut by the image)."""
        right = self.left + self.width / self.density
        bottom = self.top + self.height / self.density
        return (self.left <= -0.5, self.top <= -0.5, right >= width - 0.5, bottom >= height - 0.5)

    def to_base(self, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Window pixel (column, row) arrays, (n,) each, -> base pixels (n, 2)."""
        return np.stack(
            [self.left + (cols + 0.5) / self.density, self.top + (rows + 0.5) / self.density], -1
        )


@dataclass(frozen=True)
class View:
    """One camera into one viewport: camera name, its base intrinsics (pixels) and the window
    (None: the model's own frustum over the whole image).

    ``pose`` (world position (3,) m, rotation (3, 3) whose columns are the camera's right, up
    and backwards) places a camera that the model does not have: ``camera`` is then only its
    name, and the view is drawn from that pose through the frustum of ``focal`` and ``center``.

    ``cull`` (a whole image's view of a model camera): the part of the image (base px, density
    1) whose pixels matter; geoms that cannot reach into it are not drawn. The view keeps its
    own frustum, so every pixel inside that part is the one a full drawing gives.
    """

    camera: str
    focal: np.ndarray  # (2,) px of the base image
    center: np.ndarray  # (2,) px of the base image
    window: Window
    pose: tuple[np.ndarray, np.ndarray] | None = None
    cull: Window | None = None

    @classmethod
    def whole(cls, camera: str, height: int, width: int) -> View:
        """The camera's whole image at ``height`` × ``width`` px through its own frustum (the
        model's field of view, vertical; intrinsics are not needed and are NaN)."""
        nan = np.full(2, np.nan)
        return cls(camera, nan, nan, Window.full(height, width))

    @classmethod
    def posed(
        cls,
        camera: str,
        position: np.ndarray,
        rotation: np.ndarray,
        focal: np.ndarray,
        center: np.ndarray,
        height: int,
        width: int,
    ) -> View:
        """The whole ``height`` × ``width`` image of a pinhole camera at ``position`` (3,) m
        with ``rotation`` (3, 3) (columns: right, up, backwards), ``focal`` and ``center``
        (2,) px, that the model does not have."""
        return cls(camera, focal, center, Window.full(height, width), (position, rotation))


class ViewportRenderer:
    """Renders views side by side into one off-screen buffer of the model and reads them back.

    Created lazily (so envs pickle); by default the sensing settings of :class:`CameraRenderer`
    apply (no shadows, reflections, skybox, textures or multisampling). Its GL resources are
    freed by :meth:`close` or, when it is garbage-collected unclosed, by a finaliser; either way
    with its own context current and the previously current one restored after
    (:func:`envs.sensing.rendering.free_gl`), so other renderers of the process keep theirs.
    ``renders`` counts its calls of :meth:`render` (one read-back each), ``views_drawn`` the
    views they drew.

    Args:
        model: the MuJoCo model; its off-screen buffer is enlarged, if needed, to
            (max_height, max_width) when the context is made.
        off_flags: the ``mjtRndFlag`` names turned off (default: shadows, reflections and the
            skybox, which the sensing cameras do not need).
        textures: whether textures are drawn (the sensing cameras see flat colours).
        own_headlight: whether each view is lit by its own camera's headlight, as a renderer
            of that camera alone would light it; else every view by the first view's (the
            sensing cameras, whose colour detection was set up that way).
        plane_grid: grid spacing (m) planes are drawn with, if coarser than the model's (None:
            the model's). A plane is drawn as a grid of quads for its per-vertex lighting, fixed
            when the context is made; the scenes' fine grid costs about half of a whole view on
            software GL, and a coarse one changes only the shading of the floor's highlight.
        facets: slices and stacks of the built-in meshes (spheres, capsules, cylinders); None:
            the model's (``<visual><quality>``). Default: the sensing cameras' SPHERE_SLICES ×
            SPHERE_STACKS.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        max_height: int,
        max_width: int,
        off_flags: Sequence[str] = SENSING_OFF_FLAGS,
        textures: bool = False,
        own_headlight: bool = False,
        plane_grid: float | None = None,
        facets: tuple[int, int] | None = (SPHERE_SLICES, SPHERE_STACKS),
    ) -> None:
        self.model, self.max_height, self.max_width = model, max_height, max_width
        self.off_flags, self.textures = tuple(off_flags), textures
        self.own_headlight, self.plane_grid, self.facets = own_headlight, plane_grid, facets
        self._gl: Any = None  # the GL back-end's GLContext (its class is chosen at run time)
        self._pid = 0  # the process that made _gl
        self._context: mujoco.MjrContext | None = None
        self._scene: mujoco.MjvScene | None = None
        self._free: weakref.finalize | None = None  # frees _context and _gl, once
        self._options: dict = {}  # geom groups -> mujoco.MjvOption
        self._cameras: dict = {}  # camera name -> mujoco.MjvCamera (None: a free camera)
        self._geoms: dict = {}  # (groups, scene geoms) -> scene's model geoms, their ids
        self.renders = 0  # calls of render: one read-back each
        self.views_drawn = 0  # views drawn by them

    def _start(self) -> tuple[mujoco.MjrContext, mujoco.MjvScene]:
        """Make the GL context, the rendering context and the scene; returns the last two."""
        import mujoco

        check_gl_allowed()
        g, q = self.model.vis.global_, self.model.vis.quality
        saved = (g.offwidth, g.offheight, q.offsamples, q.numslices, q.numstacks)
        g.offwidth, g.offheight = max(g.offwidth, self.max_width), max(g.offheight, self.max_height)
        q.offsamples = 0
        if self.facets is not None:
            q.numslices, q.numstacks = self.facets  # see SPHERE_SLICES
        planes = self.model.geom_type == mjGEOM_PLANE
        grids = self.model.geom_size[planes, 2].copy()  # m
        if self.plane_grid is not None:
            self.model.geom_size[planes, 2] = np.maximum(grids, self.plane_grid)
        try:
            gl = mujoco.GLContext(g.offwidth, g.offheight)
            gl.make_current()
            context = mujoco.MjrContext(self.model, mujoco.mjtFontScale.mjFONTSCALE_100)
        except Exception as exc:  # the GL libraries raise many different types
            raise gl_start_error(exc) from exc
        finally:
            g.offwidth, g.offheight, q.offsamples, q.numslices, q.numstacks = saved
            self.model.geom_size[planes, 2] = grids
        mark_gl_started()
        # The finaliser holds both until it runs, so neither is freed on its own, in the wrong
        # order or under another renderer's context (see free_gl).
        self._free = weakref.finalize(self, free_gl, gl, context)
        self._gl, self._context, self._pid = gl, context, os.getpid()
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, context)
        scene = self._scene = mujoco.MjvScene(self.model, maxgeom=1000)
        for flag in self.off_flags:
            scene.flags[getattr(mujoco.mjtRndFlag, flag)] = 0
        return context, scene

    def _started(self) -> tuple[mujoco.MjrContext, mujoco.MjvScene]:
        """The rendering context and the scene, made at the first call."""
        if self._context is None or self._scene is None:
            return self._start()
        check_same_process(self._pid)
        return self._context, self._scene

    def _option(self, groups: tuple[int, ...]):
        import mujoco

        option = self._options.get(groups)
        if option is None:
            option = mujoco.MjvOption()
            option.flags[mujoco.mjtVisFlag.mjVIS_TEXTURE] = int(self.textures)
            option.geomgroup[:] = 0
            for g in groups:
                option.geomgroup[g] = 1
            self._options[groups] = option
        return option

    def _camera(self, view: View):
        """The MjvCamera of a model camera, or a free one for a posed view (placed later)."""
        import mujoco

        name = None if view.pose is not None else view.camera
        cam = self._cameras.get(name)
        if cam is None:
            cam = mujoco.MjvCamera()
            if name is None:
                cam.type = mujoco.mjtCamera.mjCAMERA_FREE
            else:
                cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
                cam.fixedcamid = self.model.camera(name).id
            self._cameras[name] = cam
        return cam

    def _model_geoms(
        self, scene: mujoco.MjvScene, groups: tuple[int, ...]
    ) -> tuple[list, np.ndarray]:
        """The scene's geoms that are model geoms, and their ids (n,), after an update with
        ``groups`` (the same for every update with the same groups)."""
        import mujoco

        key = (groups, scene.ngeom)
        if key not in self._geoms:
            geoms = [g for g in scene.geoms[: scene.ngeom] if g.objtype == mujoco.mjtObj.mjOBJ_GEOM]
            self._geoms[key] = (geoms, np.array([g.objid for g in geoms], dtype=int))
        return self._geoms[key]

    @overload
    def render(
        self,
        data: mujoco.MjData,
        views: Sequence[View],
        groups: Sequence[int],
        depth: Literal[True] = True,
    ) -> list[tuple[np.ndarray, np.ndarray]]: ...

    @overload
    def render(
        self, data: mujoco.MjData, views: Sequence[View], groups: Sequence[int], depth: bool
    ) -> list[tuple[np.ndarray, np.ndarray | None]]: ...

    def render(
        self, data: mujoco.MjData, views: Sequence[View], groups: Sequence[int], depth: bool = True
    ) -> Sequence[tuple[np.ndarray, np.ndarray | None]]:
        """RGB (h, w, 3) uint8 and depth (h, w) m of each view, rows top first; with
        ``depth=False`` only the colours are read back (depth None)."""
        import mujoco

        context, scene = self._started()
        self._gl.make_current()
        widths = [v.window.width for v in views]
        height = max(v.window.height for v in views)
        if sum(widths) > self.max_width or height > self.max_height:
            raise ValueError(
                f"views of {sum(widths)}x{height} px exceed this renderer's "
                f"{self.max_width}x{self.max_height}; make it larger"
            )
        option = self._option(tuple(groups))
        self.renders += 1
        self.views_drawn += len(views)
        x = 0
        mujoco.mjv_updateScene(
            self.model, data, option, None, self._camera(views[0]),
            mujoco.mjtCatBit.mjCAT_ALL, scene,
        )  # fmt: skip
        culling = (
            None  # the scene's model geoms and their bounding capsules, once windows need them
        )
        for k, view in enumerate(views):
            if k > 0:
                mujoco.mjv_updateCamera(self.model, data, self._camera(view), scene)
            if view.pose is not None:
                place_camera(scene, view)
            if self.own_headlight and (k > 0 or view.pose is not None):
                mujoco.mjv_makeLights(self.model, data, scene)
            hidden = []
            window = (
                view.window.density != 1.0 or view.window.left != -0.5 or view.window.top != -0.5
            )
            part = view.window if window else view.cull
            if view.pose is None and part is not None:  # a posed view: framed by place_camera
                if culling is None:
                    geoms, ids = self._model_geoms(scene, tuple(groups))
                    culling = (geoms, *_bounding_capsules(self.model, data, ids))
                whole = [_frustum(glcam) for glcam in scene.camera]
                _set_frustum(scene, View(view.camera, view.focal, view.center, part))
                hidden = _hide_outside(scene, *culling, part.depth)
                if not window:  # culled with the part's frustum, drawn with the whole one
                    for glcam, kept in zip(scene.camera, whole, strict=True):
                        _restore_frustum(glcam, kept)
            w = view.window
            mujoco.mjr_render(mujoco.MjrRect(x, 0, w.width, w.height), scene, context)
            for geom, kind in hidden:
                geom.type = kind
            x += w.width
        rgb = np.empty((height, x, 3), dtype=np.uint8)
        raw = np.empty((height, x), dtype=np.float32) if depth else None
        mujoco.mjr_readPixels(rgb, raw, mujoco.MjrRect(0, 0, x, height), context)
        rgb = rgb[::-1]  # GL rows are bottom first
        if raw is not None:
            raw = raw[::-1]
            near, far = scene.camera[0].frustum_near, scene.camera[0].frustum_far
        out, x = [], 0
        for view in views:
            w = view.window
            rows = slice(height - w.height, height)
            cols = slice(x, x + w.width)
            metres = None
            if raw is not None:
                metres = near * far / (far - raw[rows, cols].astype(np.float64) * (far - near))
            out.append((rgb[rows, cols], metres))
            x += w.width
        return out

    def close(self) -> None:
        """Free the GL resources now (a later render makes new ones)."""
        if self._free is not None:
            self._free()
            self._free = self._gl = self._context = self._scene = None
            self._geoms = {}  # they were the freed scene's

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_gl": None, "_context": None, "_scene": None, "_free": None,
                "_options": {}, "_cameras": {}, "_geoms": {}}  # fmt: skip


def place_camera(scene, view: View) -> None:
    """Put the scene's cameras at a posed view's pose (:attr:`View.pose`), with the frustum of
    its intrinsics (MuJoCo draws a free camera from wherever its GL cameras are)."""
    position, rotation = view.pose  # type: ignore[misc]  # a posed view's
    for glcam in scene.camera:
        glcam.pos[:] = position
        glcam.forward[:] = -rotation[:, 2]
        glcam.up[:] = rotation[:, 1]
        glcam.orthographic = 0
    _set_frustum(scene, view)


def _set_frustum(scene, view: View) -> None:
    """The near-plane rectangle of the view's window (MuJoCo sets left and right from the
    viewport's aspect ratio about ``frustum_center``, so pixels must be square)."""
    (fu, fv), (cu, cv), w = view.focal, view.center, view.window
    if abs(fu - fv) > SQUARE_PIXEL_TOL * fu:
        raise ValueError(f"camera {view.camera}: windows need square pixels, focal is {fu}, {fv}")
    for glcam in scene.camera:
        near = glcam.frustum_near
        right = w.left + w.width / w.density
        bottom = w.top + w.height / w.density
        glcam.frustum_center = ((w.left + right) / 2 - cu) / fu * near
        glcam.frustum_width = (right - w.left) / 2 / fu * near  # half-width, used when set
        glcam.frustum_top = (cv - w.top) / fv * near
        glcam.frustum_bottom = (cv - bottom) / fv * near


def _frustum(glcam) -> tuple[float, float, float, float]:
    """A GL camera's frustum fields (centre, half-width, top, bottom), to restore later."""
    return glcam.frustum_center, glcam.frustum_width, glcam.frustum_top, glcam.frustum_bottom


def _restore_frustum(glcam, frustum: tuple[float, float, float, float]) -> None:
    glcam.frustum_center, glcam.frustum_width, glcam.frustum_top, glcam.frustum_bottom = frustum


def _bounding_capsules(
    model: mujoco.MjModel, data: mujoco.MjData, ids: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Capsules that contain the geoms ``ids`` (n,): segment ends (n, 2, 3) m and radii (n,) m.

    A capsule or cylinder is bounded by the capsule of its own radius about its axis (a long
    link's bounding sphere would reach far beyond it); any other geom by its bounding sphere
    (both ends at its centre), a plane (no bounding sphere, rbound 0) by an infinite one."""
    centres = data.geom_xpos[ids]  # (n, 3)
    axes = data.geom_xmat[ids][:, 2::3]  # (n, 3) the geoms' local z axes in world
    size = model.geom_size[ids]
    kind = model.geom_type[ids]
    long = (kind == mjGEOM_CAPSULE) | (kind == mjGEOM_CYLINDER)
    half = np.where(long, size[:, 1], 0.0)[:, None] * axes  # (n, 3)
    ends = np.stack([centres - half, centres + half], axis=1)
    reach = np.where(long, size[:, 0], model.geom_rbound[ids])
    return ends, np.where(reach > 0, reach, np.inf)


def _hide_outside(scene, geoms: list, ends: np.ndarray, reach: np.ndarray, depth: float) -> list:
    """Hide (type NONE) those of ``geoms`` (MjvGeoms of ``scene``, inside capsules of segment
    ``ends`` (n, 2, 3) m and radii ``reach`` (n,) m) that lie wholly outside the frustum of the
    scene's camera (after :func:`_set_frustum`: the window's) or beyond ``depth`` (m along the
    optical axis); returns (geom, type) pairs to restore. Such a geom draws no pixel in the
    window (or none that matters, see :class:`Window`), but costs its triangles. A capsule is
    outside a plane when both ends are farther than its radius on the outer side."""
    import mujoco

    cam = scene.camera[0]
    (f0, f1, f2), (u0, u1, u2) = cam.forward, cam.up
    right = (f1 * u2 - f2 * u1, f2 * u0 - f0 * u2, f0 * u1 - f1 * u0)  # forward × up
    basis = np.array([right, (u0, u1, u2), (f0, f1, f2)])  # rows: camera x right, y up, depth
    near, centre, half = cam.frustum_near, cam.frustum_center, cam.frustum_width
    left, right_, bottom, top = centre - half, centre + half, cam.frustum_bottom, cam.frustum_top
    # Inward normals (camera coordinates) of the frustum's side planes and of the camera plane.
    normals = np.array(
        [[near, 0, -left], [-near, 0, right_], [0, near, -bottom], [0, -near, top], [0, 0, 1.0]]
    )
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    local = (ends - np.asarray(cam.pos)) @ basis.T  # (n, 2, 3) camera coordinates, m
    side = (local @ normals.T).max(axis=1)  # (n, 5) the nearer end's distance inside each plane
    outside = (side < -reach[:, None]).any(1) | (local[:, :, 2].min(1) - reach > depth)
    hidden = [(geoms[i], geoms[i].type) for i in np.flatnonzero(outside)]
    for g, _ in hidden:
        g.type = mujoco.mjtGeom.mjGEOM_NONE
    return hidden
