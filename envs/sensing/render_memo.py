"""Renderings kept for reuse: the sensing cameras do not draw a view again while nothing it
shows has changed (the reach task's arm back at its start pose at every reset, drawn without
the target, which moved).

A rendering is known by everything it reads that can change between calls (:func:`scene_key`):
the views (cameras, intrinsics, windows), the geom groups drawn, the poses, sizes, colours,
materials and kinds of the geoms in those groups, the poses of the sites MuJoCo draws, the
cameras' poses and fields of view, and the lights. The renderer's own settings and the model's
visual options (``model.vis``: headlight, clipping planes) are fixed when it is made; a caller
that edits those turns reuse off (``StereoRig.reuse_renders``).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from envs.sensing.viewports import View

if TYPE_CHECKING:
    import mujoco  # imported at run time only where used: envs picks the GL back-end first

#: Renderings kept: a reset's whole images of the arm and the windows placed from them, with
#: room for the renderings in between (see :class:`RenderMemo` for which one goes).
KEPT_RENDERINGS = 8
#: Site groups MuJoCo draws with its default options (``MjvOption.sitegroup``), which the
#: sensing renderer keeps.
DRAWN_SITE_GROUPS = (0, 1, 2)

Images = list[tuple[np.ndarray, np.ndarray]]  # (RGB (h, w, 3) uint8, depth (h, w) m) per view
Key = tuple[tuple[int, ...], tuple, bytes]


def drawn_ids(model: mujoco.MjModel, groups: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Ids of the geoms in ``groups`` and of the sites MuJoCo draws (DRAWN_SITE_GROUPS)."""
    geoms = np.flatnonzero([g in groups for g in model.geom_group.tolist()])
    sites = np.flatnonzero([g in DRAWN_SITE_GROUPS for g in model.site_group.tolist()])
    return geoms, sites


def scene_key(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    groups: Sequence[int],
    views: Sequence[View],
    ids: tuple[np.ndarray, np.ndarray] | None = None,
) -> Key:
    """What a rendering of ``views`` drawing the geom ``groups`` depends on, as a dict key: two
    calls with equal keys draw the same pixels. ``ids``: :func:`drawn_ids` of the model and
    ``groups``, if known."""
    geoms, sites = drawn_ids(model, groups) if ids is None else ids
    state = (
        model.geom_group,
        model.geom_type,
        model.geom_size,
        model.geom_rgba,
        model.geom_dataid,
        model.geom_matid,
        model.cam_fovy,
        model.cam_intrinsic,
        model.cam_sensorsize,
        model.mat_rgba,
        model.site_group,
        model.site_size,
        model.site_rgba,
        model.light_active,
        model.light_ambient,
        model.light_diffuse,
        model.light_specular,
        data.geom_xpos[geoms],
        data.geom_xmat[geoms],
        data.site_xpos[sites],
        data.site_xmat[sites],
        data.cam_xpos,
        data.cam_xmat,
        data.light_xpos,
        data.light_xdir,
    )
    shown = tuple(
        (
            v.camera,
            v.focal.tobytes(),
            v.center.tobytes(),
            v.window,
            None if v.pose is None else (v.pose[0].tobytes(), v.pose[1].tobytes()),
            v.cull,
        )
        for v in views
    )
    return tuple(groups), shown, b"".join(a.tobytes() for a in state)


class RenderMemo:
    """Up to KEPT_RENDERINGS renderings by their :func:`scene_key`; their images are read-only
    (every caller shares them). When full, a new rendering takes the place of the oldest one
    that was never reused (the views of a pose the arm passed through), else of the oldest."""

    def __init__(self, kept: int = KEPT_RENDERINGS) -> None:
        self.kept = kept
        self._images: OrderedDict[Key, Images] = OrderedDict()  # least recently used first
        self._reused: set[Key] = set()  # keys of renderings that were reused
        self._ids: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}  # see key()
        self.reused = 0  # renderings not drawn again

    def key(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        groups: Sequence[int],
        views: Sequence[View],
    ) -> Key:
        """:func:`scene_key`, with the drawn ids found once per model grouping and groups."""
        known = (tuple(groups), model.geom_group.tobytes(), model.site_group.tobytes())
        ids = self._ids.get(known)
        if ids is None:
            ids = self._ids[known] = drawn_ids(model, groups)
        return scene_key(model, data, groups, views, ids)

    def get(self, key: Key, draw: Callable[[], Images]) -> Images:
        """The images kept for ``key``, else those of ``draw()`` (then kept)."""
        images = self._images.get(key)
        if images is not None:
            self._images.move_to_end(key)
            self._reused.add(key)
            self.reused += 1
            return images
        images = draw()
        for rgb, depth in images:
            rgb.setflags(write=False)
            depth.setflags(write=False)
        if len(self._images) >= self.kept:
            old = next((k for k in self._images if k not in self._reused), None)
            old = next(iter(self._images)) if old is None else old
            del self._images[old]
            self._reused.discard(old)
        self._images[key] = images
        return images

    def clear(self) -> None:
        self._images.clear()
        self._reused.clear()

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_images": OrderedDict(), "_reused": set()}  # not sent along
