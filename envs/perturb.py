"""Changes of the world at run time: what makes a calibrated model go stale.

A :class:`Perturbation` moves and turns each camera, zooms both lenses, moves the sensed point
along the arm (a longer tool, a re-attached marker) and shifts the robot's base. It is applied to
a reach env's MuJoCo model in place, between trials, relative to the nominal scene (each change
replaces the previous one; ``Perturbation()`` restores the nominal scene). Rendering reads the
model, so the cameras, the composite view and the marker follow; the env's ``StereoRig`` re-reads
its cameras. The env's ``nominal_stereo`` keeps the cameras as built: that is the calibration the
exact baselines use.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import mujoco
import numpy as np

from envs import arguments
from envs.robots import RobotSpec, robot_spec
from envs.sensing.stereo import CameraPair, PinholeCamera
from models.rotations import rotvec_to_matrix
from models.workspace import Workspace

CAMERAS = ("cam_left", "cam_right")
MIN_ZOOM, MAX_ZOOM = 0.5, 2.0  # focal length factors accepted
MAX_OFFSET = 0.5  # m: largest camera shift, base shift or tool extension accepted
MAX_TURN = np.pi / 2  # rad: largest camera turn accepted
#: A change is refused unless at least this fraction of the workspace stays in both images.
MIN_IN_VIEW = 0.99
VIEW_CHECK_POINTS = 500  # workspace points drawn (fixed seed) for that check
VIEW_CHECK_SEED = 0


class PerturbationError(ValueError):
    """A change that cannot be applied (not finite, too large, or the workspace out of view)."""


#: The accepted shapes of each array field: per camera (2, 3), or (3,) for both.
CAMERA_SHAPES = ((2, 3), (3,))


def _vectors(
    value: Any, shapes: tuple[tuple[int, ...], ...], name: str, limit: float, unit: str
) -> np.ndarray:
    """``value`` checked (real numbers of an accepted shape, finite, each vector's norm at most
    ``limit``) and broadcast to the first shape; PerturbationError naming ``name`` else."""
    a = arguments.real_numbers(name, value, f"real numbers ({unit})", PerturbationError)
    if a.shape not in shapes:
        valid = " or ".join(map(str, shapes))
        raise PerturbationError(f"{name} must have shape {valid} ({unit}), got shape {a.shape}")
    a = np.broadcast_to(a, shapes[0]).copy()
    if not np.isfinite(a).all():
        raise PerturbationError(f"{name} must be finite, got {a.tolist()}")
    if np.linalg.norm(a, axis=-1).max() > limit:
        raise PerturbationError(f"{name} {a.tolist()} is larger than {limit}; pass a smaller one")
    return a


def _number(value: Any, name: str, unit: str) -> float:
    """One real number (a 0-d array counts), else PerturbationError naming ``name``."""
    a = arguments.real_numbers(name, value, f"a real number ({unit})", PerturbationError)
    if a.shape != ():
        raise PerturbationError(f"{name} must be one number ({unit}), got shape {a.shape}")
    return float(a)


@dataclass(frozen=True, eq=False)  # arrays: compare fields explicitly
class Perturbation:
    """A change of the scene relative to its nominal state.

    Attributes:
        camera_shift: (2, 3) m, world translation of cam_left and cam_right ((3,) for both).
        camera_turn: (2, 3) rad, rotation vector (world axes) turning each camera about its centre.
        zoom: focal length factor of both cameras (1.05 = 5 % longer focal length).
        tool: m, the sensed point and its marker moved outward along the arm (RIACS: link 2
            longer; PUMA wrist: along the forearm; PUMA tool point: along the tool axis).
        base_shift: (3,) m, world translation of the robot (targets are drawn in the shifted
            workspace).
    """

    camera_shift: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))
    camera_turn: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))
    zoom: float = 1.0
    tool: float = 0.0
    base_shift: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        shift = _vectors(self.camera_shift, CAMERA_SHAPES, "camera_shift", MAX_OFFSET, "m")
        set_(self, "camera_shift", shift)
        turn = _vectors(self.camera_turn, CAMERA_SHAPES, "camera_turn", MAX_TURN, "rad")
        set_(self, "camera_turn", turn)
        set_(self, "base_shift", _vectors(self.base_shift, ((3,),), "base_shift", MAX_OFFSET, "m"))
        tool = _number(self.tool, "tool", "m")
        if not math.isfinite(tool) or abs(tool) > MAX_OFFSET:
            raise PerturbationError(f"tool must be in [-{MAX_OFFSET}, {MAX_OFFSET}] m, got {tool}")
        set_(self, "tool", tool)
        zoom = _number(self.zoom, "zoom", "focal length factor")
        if not MIN_ZOOM <= zoom <= MAX_ZOOM:  # also refuses NaN
            raise PerturbationError(f"zoom must be in [{MIN_ZOOM}, {MAX_ZOOM}], got {self.zoom}")
        set_(self, "zoom", zoom)

    @classmethod
    def of(cls, change: Any) -> Perturbation:
        """A Perturbation from itself, a mapping of its fields, or None (the nominal scene);
        PerturbationError naming what is wrong for anything else."""
        if isinstance(change, Perturbation):
            return change
        if change is not None and not isinstance(change, Mapping):
            raise PerturbationError(
                f"a change must be a Perturbation, a dict of its fields ({', '.join(FIELDS)}) "
                f"or None, got {change!r}"
            )
        change = dict(change or {})
        unknown = set(change) - set(FIELDS)
        if unknown:
            raise PerturbationError(
                f"unknown perturbation fields {sorted(unknown, key=repr)}; "
                f"valid: {', '.join(FIELDS)}"
            )
        return cls(**change)

    @classmethod
    def random(
        cls,
        rng: np.random.Generator,
        camera_shift: float = 0.0,
        camera_turn: float = 0.0,
        zoom: float = 0.0,
        tool: float = 0.0,
        base_shift: float = 0.0,
    ) -> Perturbation:
        """A random change of the given sizes: each camera moved ``camera_shift`` m in a random
        direction and turned ``camera_turn`` rad about a random axis, the focal length changed by
        ±``zoom`` (a fraction), the tool ±``tool`` m, the base moved ``base_shift`` m.

        Raises:
            PerturbationError: a size that is not a number >= 0 or exceeds its largest change
                (:data:`RANDOM_LIMITS`), before any number is drawn from ``rng``.
        """
        random_sizes(
            {
                "camera_shift": camera_shift,
                "camera_turn": camera_turn,
                "zoom": zoom,
                "tool": tool,
                "base_shift": base_shift,
            }
        )

        def directions(n: int) -> np.ndarray:
            d = rng.normal(size=(n, 3))
            return d / np.linalg.norm(d, axis=-1, keepdims=True)

        return cls(
            camera_shift=camera_shift * directions(2),
            camera_turn=camera_turn * directions(2),
            zoom=1.0 + zoom * rng.choice([-1.0, 1.0]),
            tool=tool * rng.choice([-1.0, 1.0]),
            base_shift=base_shift * directions(1)[0],
        )

    def describe(self) -> str:
        """One line in mm, degrees and %, for logs and plots."""
        parts = []
        if np.any(self.camera_shift):
            mm = np.linalg.norm(self.camera_shift, axis=-1) * 1e3
            parts.append(f"cameras moved {mm[0]:.0f}/{mm[1]:.0f} mm")
        if np.any(self.camera_turn):
            deg = np.rad2deg(np.linalg.norm(self.camera_turn, axis=-1))
            parts.append(f"turned {deg[0]:.1f}/{deg[1]:.1f} deg")
        if self.zoom != 1.0:
            parts.append(f"focal length {100 * (self.zoom - 1):+.1f} %")
        if self.tool:
            parts.append(f"tool {self.tool * 1e3:+.0f} mm")
        if np.any(self.base_shift):
            parts.append(f"base moved {np.linalg.norm(self.base_shift) * 1e3:.0f} mm")
        return ", ".join(parts) or "nominal scene"


FIELDS = tuple(f.name for f in fields(Perturbation))
#: Largest size of each random change and its unit: the field's limit (zoom: the factor
#: 1 ± size stays in [MIN_ZOOM, MAX_ZOOM]).
RANDOM_LIMITS = {
    "camera_shift": (MAX_OFFSET, "m"),
    "camera_turn": (MAX_TURN, "rad"),
    "zoom": (min(1.0 - MIN_ZOOM, MAX_ZOOM - 1.0), "fraction of the focal length"),
    "tool": (MAX_OFFSET, "m"),
    "base_shift": (MAX_OFFSET, "m"),
}


def random_sizes(sizes: Any) -> dict[str, float]:
    """Sizes for :meth:`Perturbation.random` from a mapping of field names to numbers in
    [0, :data:`RANDOM_LIMITS`]; PerturbationError naming the field and what it takes else."""
    if not isinstance(sizes, Mapping):
        raise PerturbationError(
            f"random sizes must be a dict of field names to sizes ({', '.join(FIELDS)}), "
            f"got {sizes!r}"
        )
    unknown = set(sizes) - set(FIELDS)
    if unknown:
        raise PerturbationError(
            f"unknown random sizes {sorted(unknown, key=repr)}; valid: {', '.join(FIELDS)}"
        )
    checked = {}
    for name, value in sizes.items():
        limit, unit = RANDOM_LIMITS[name]
        size = _number(value, f"random size {name}", unit)
        if not 0.0 <= size <= limit:  # also refuses NaN
            raise PerturbationError(
                f"random size {name} must be in [0, {limit}] ({unit}), got {value!r}"
            )
        checked[name] = size
    return checked


class SceneEditor:
    """Applies perturbations to one env's model, remembering the nominal values.

    Args:
        model, data: the env's MuJoCo model and data (after ``mj_forward`` at the nominal state).
        robot: a key of :data:`envs.robots.ROBOTS`; site, markers: the sensed site and the
            marker geoms that move with it (the green marker; the hand's three) along the
            site's tool axis (:attr:`~envs.robots.RobotSpec.tool_axes`).
        nominal: the nominal cameras (pixels of the env's image size).
        width, height: the env's sensing image size, px.
    """

    def __init__(
        self,
        model,
        data,
        robot: str | RobotSpec,
        site: str,
        markers: Sequence[str],
        nominal: CameraPair,
        width: int,
        height: int,
    ) -> None:
        self.model, self.nominal, self.width, self.height = model, nominal, width, height
        self._cams = [model.camera(c).id for c in CAMERAS]
        if any(model.cam_mode[c] != mujoco.mjtCamLight.mjCAMLIGHT_FIXED for c in self._cams):
            raise ValueError("perturb needs fixed cameras (mode 'fixed')")
        self._cam_pos = model.cam_pos[self._cams].copy()  # (2, 3), in the world (worldbody)
        self._cam_mat = data.cam_xmat[self._cams].reshape(2, 3, 3).copy()
        self._intrinsic = model.cam_intrinsic[self._cams].copy()
        self._fovy = model.cam_fovy[self._cams].copy()  # deg
        self._site = model.site(site).id
        self._marker = np.array([model.geom(name).id for name in markers])
        # A site or geom compiled as sitting at its body's frame ignores its pos: let it move.
        model.site_sameframe[self._site] = model.geom_sameframe[self._marker] = 0
        self._site_pos = model.site_pos[self._site].copy()
        self._marker_pos = model.geom_pos[self._marker].copy()
        self._tool_axis = np.array(robot_spec(robot).tool_axes[site])
        self._root = int(model.body_rootid[model.site_bodyid[self._site]])
        self._root_pos = model.body_pos[self._root].copy()

    def cameras(self, change: Perturbation) -> list[PinholeCamera]:
        """The nominal cameras as ``change`` moves, turns and zooms them."""
        return [
            PinholeCamera(
                cam.position + change.camera_shift[k],
                rotvec_to_matrix(change.camera_turn[k]) @ cam.rotation,
                cam.focal * change.zoom,
                cam.center,
            )
            for k, cam in enumerate(self.nominal.cameras)
        ]

    def check(self, change: Perturbation, workspace: Workspace) -> None:
        """Raise PerturbationError if the changed cameras lose sight of the workspace."""
        points = workspace.sample(np.random.default_rng(VIEW_CHECK_SEED), VIEW_CHECK_POINTS)
        pixels, depth = CameraPair(self.cameras(change)).project_with_depth(
            points + change.base_shift
        )
        u, v = pixels[:, 0::2], pixels[:, 1::2]  # (N, 2)
        seen = (depth > 0) & (u >= 0) & (u <= self.width - 1) & (v >= 0) & (v <= self.height - 1)
        fraction = seen.all(axis=1).mean()
        if fraction < MIN_IN_VIEW:
            raise PerturbationError(
                f"after {change.describe()} only {100 * fraction:.1f} % of the workspace is in "
                f"both images (at least {100 * MIN_IN_VIEW:.0f} % needed); pass a smaller change"
            )

    def apply(self, change: Perturbation) -> None:
        """Write ``change`` into the model (call ``mj_forward`` and refresh the rig after)."""
        m = self.model
        for k, cid in enumerate(self._cams):
            m.cam_pos[cid] = self._cam_pos[k] + change.camera_shift[k]
            turned = rotvec_to_matrix(change.camera_turn[k]) @ self._cam_mat[k]
            mujoco.mju_mat2Quat(m.cam_quat[cid], turned.ravel())
            if m.cam_sensorsize[cid][1] > 0:  # physical sensor: focal length in intrinsic[:2]
                m.cam_intrinsic[cid, :2] = self._intrinsic[k, :2] * change.zoom
            else:  # field of view: tan(fovy / 2) shrinks as the focal length grows
                half = np.arctan(np.tan(np.deg2rad(self._fovy[k]) / 2) / change.zoom)
                m.cam_fovy[cid] = np.rad2deg(2 * half)
        m.site_pos[self._site] = self._site_pos + change.tool * self._tool_axis
        m.geom_pos[self._marker] = self._marker_pos + change.tool * self._tool_axis
        m.body_pos[self._root] = self._root_pos + change.base_shift
