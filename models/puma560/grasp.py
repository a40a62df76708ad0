"""The PUMA 560's grasp task: where the hand must be, and how its pose is seen.

The target object and the hand carry the same frame of three coloured marker spheres, at
:data:`~models.marker_frame.MARKER_OFFSETS` in their own frames (:mod:`models.marker_frame`, the
same on every arm; the PUMA's hand frame is DH frame 6, the tool point ``tcp``). The hand grasps
the object when the two frames coincide.

Where the markers sit. The cameras look at the workspace from the front (world +y) and above;
at :data:`NOMINAL_ORIENTATION` the tool's x axis points along their line of sight, its y axis
across the images and its z axis (the approach direction) down. Offsets along tool x therefore
hardly move a marker in the images, and markers at the tool point itself are hidden by the
fingers and the wrist. The three markers lie in the tool's y-z plane instead: red and green on
a 160 mm crossbar along tool y, 20 mm beyond the flange (beside the wrist's silhouette, outside
the fingers), blue 140 mm down the tool axis below the fingertips, a T whose sides are seen
nearly face-on by both cameras. Over 2 000 poses of :func:`sample_grasp_pose` (projection at
320 × 240) the closest two markers are at least 9.4 px apart in both images (1 % of poses below
12.4 px, median 22.6 px; 0.1 m offsets along tool x and y left 1 % below 3.1 px), and every
marker is at least 5 px inside both images in 99.75 % of poses (the rest are poses at the
bottom or the sides of the box, where the blue marker or one end of the crossbar nears the
border).

All positions are in metres; the world frame is DH frame 0 shifted by
:data:`~models.puma560.BASE_POS` (same axes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from models.grasp_task import GraspTask
from models.marker_frame import HAND_COLOURS as HAND_COLOURS  # the marker frame, read here too
from models.marker_frame import MARKER_COLOURS as MARKER_COLOURS
from models.marker_frame import MARKER_OFFSETS as MARKER_OFFSETS
from models.marker_frame import marker_points as marker_points
from models.marker_frame import orientation_angle as orientation_angle
from models.marker_frame import pose_from_points as pose_from_points
from models.puma560.inverse import pose_ik, pose_ik_all
from models.puma560.kinematics import DH, frames, jacobian
from models.puma560.workspace import BASE_POS
from models.rotations import homogeneous, rotvec_to_matrix
from models.workspace import BoxWorkspace

#: The taught keyframe ``ready`` (rad), the one pose a learner is given.
READY = np.array([-1.2963, -2.2265, -0.2073, 0.0, -0.818, 0.2745])
#: The hand's orientation at ``ready`` (world axes): the centre of the narrow range.
NOMINAL_ORIENTATION = frames(READY)[6, :3, :3]
#: Largest angle of the narrow range (the first releases' only one) from
#: :data:`NOMINAL_ORIENTATION` (rad), about any axis.
MAX_TILT = math.radians(30.0)
#: The branch of the narrow range (right arm, elbow above, wrist flip -1: ``ready``'s branch).
BRANCH = (1, 1, -1)
#: The arm configuration of every range (right arm, elbow above: ``ready``'s); the wide range
#: takes ``ready``'s wrist flip where it can, else the other (:func:`grasp_joints`).
ARM_CONFIGURATION = BRANCH[:2]


def _upright(R: np.ndarray) -> np.ndarray:
    """``R`` turned by the smallest rotation that points its z axis (the approach) straight
    down, -world z."""
    z, down = R[:, 2], np.array([0.0, 0.0, -1.0])
    axis = np.cross(z, down)
    norm = float(np.linalg.norm(axis))
    if norm < 1e-15:
        return np.array(R, dtype=float)
    return rotvec_to_matrix(axis / norm * math.atan2(norm, float(z @ down))) @ R


#: ``NOMINAL_ORIENTATION`` with its approach turned straight down (6.3° away): the wide
#: range's yaw 0, tilt 0.
UPRIGHT_ORIENTATION = _upright(NOMINAL_ORIENTATION)


@dataclass(frozen=True)
class OrientationRange:
    """The orientations objects are drawn from.

    ``kind="yaw_tilt"`` (the default range): the hand upright (:data:`UPRIGHT_ORIENTATION`,
    approach straight down), turned about the vertical by a yaw uniform in [-yaw, yaw], then its
    approach tilted from the vertical by an angle uniform over the spherical cap up to ``tilt``
    (towards a uniform direction). ``kind="ball"``: uniform in the ball of rotations within
    ``tilt`` of :data:`NOMINAL_ORIENTATION` about any axis (``yaw`` unused, 0): the first
    releases' range with ``tilt`` = 30°. Angles in radians.

    Spelled for command lines and run files as ``"yaw:90,tilt:45"`` or ``"ball:30"`` (degrees):
    :meth:`parse` and :meth:`spec`.
    """

    kind: str = "yaw_tilt"
    yaw: float = math.radians(90.0)
    tilt: float = math.radians(45.0)

    def __post_init__(self) -> None:
        if self.kind not in ORIENTATION_KINDS:
            raise ValueError(
                f"orientation range kind {self.kind!r}; valid: {', '.join(ORIENTATION_KINDS)}"
            )
        for name, value, most in (("yaw", self.yaw, math.pi), ("tilt", self.tilt, MOST_TILT)):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"orientation range {name} must be a number (rad), got {value!r}")
            if not 0.0 <= value <= most:
                raise ValueError(
                    f"orientation range {name} is {math.degrees(value):.4g}°; it must lie in "
                    f"[0, {math.degrees(most):.4g}]° (the PUMA's wrist reaches no further here)"
                )
            object.__setattr__(self, name, float(value))
        if self.kind == "ball" and self.yaw != 0.0:
            raise ValueError("a ball orientation range has no yaw; give tilt only ('ball:30')")

    @classmethod
    def ball(cls, angle: float) -> OrientationRange:
        """The ball of rotations within ``angle`` (rad) of :data:`NOMINAL_ORIENTATION`."""
        return cls("ball", 0.0, angle)

    @classmethod
    def parse(cls, text: str | OrientationRange) -> OrientationRange:
        """``"yaw:90,tilt:45"`` or ``"ball:30"`` (degrees); an OrientationRange passes through."""
        if isinstance(text, OrientationRange):
            return text
        usage = "give 'yaw:DEG,tilt:DEG' (e.g. 'yaw:90,tilt:45') or 'ball:DEG' (e.g. 'ball:30')"
        if not isinstance(text, str):
            raise ValueError(f"orientation range {text!r} is not a string; {usage}")
        try:
            parts = dict(part.split(":") for part in text.replace(" ", "").split(","))
            degrees = {k: float(v) for k, v in parts.items()}
        except ValueError:
            raise ValueError(f"orientation range {text!r} cannot be read; {usage}") from None
        if set(degrees) == {"ball"}:
            return cls.ball(math.radians(degrees["ball"]))
        if set(degrees) == {"yaw", "tilt"}:
            return cls("yaw_tilt", math.radians(degrees["yaw"]), math.radians(degrees["tilt"]))
        raise ValueError(f"orientation range {text!r} names {sorted(degrees)}; {usage}")

    def spec(self) -> str:
        """The range as :meth:`parse` reads it (degrees, as short as exact)."""

        def deg(x: float) -> str:
            return f"{math.degrees(x):.10g}"

        if self.kind == "ball":
            return f"ball:{deg(self.tilt)}"
        return f"yaw:{deg(self.yaw)},tilt:{deg(self.tilt)}"

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """One orientation (3, 3) drawn from the range with ``rng``."""
        if self.kind == "ball":
            axis = rng.normal(size=3)
            axis /= np.linalg.norm(axis)
            angle = self.tilt * rng.random() ** (1.0 / 3.0)  # uniform in the ball of rotvecs
            return rotvec_to_matrix(axis * angle) @ NOMINAL_ORIENTATION
        yaw = rng.uniform(-self.yaw, self.yaw)
        azimuth = rng.uniform(0.0, 2.0 * math.pi)
        tilt = math.acos(1.0 - rng.random() * (1.0 - math.cos(self.tilt)))  # uniform on the cap
        turn = rotvec_to_matrix(np.array([0.0, 0.0, yaw]))
        lean = rotvec_to_matrix(tilt * np.array([math.cos(azimuth), math.sin(azimuth), 0.0]))
        return lean @ turn @ UPRIGHT_ORIENTATION


#: The kinds of :class:`OrientationRange`.
ORIENTATION_KINDS = ("yaw_tilt", "ball")
#: rad: the largest tilt a range may ask for (the wrist's bend, joint 5, reaches ±100°; past
#: 80° from the vertical the approach points sideways and the cameras see the hand edge-on).
MOST_TILT = math.radians(80.0)
#: The default range: objects turned any way a hand picking them from a table meets them.
WIDE = OrientationRange()
#: The first releases' range: within 30° of the hand's orientation at ``ready``.
NARROW = OrientationRange.ball(MAX_TILT)


def grasp_joints(T06: np.ndarray, orientations: OrientationRange) -> np.ndarray | None:
    """The joints (6,) that put frame 6 at ``T06`` (frame 0) in a branch the range allows, or
    None when no such branch has every joint in range.

    The narrow range keeps :data:`BRANCH` only (as the first releases did); the others take
    :data:`ARM_CONFIGURATION` with ``ready``'s wrist flip where every joint is in range, else
    with the other flip (poses past the wrist singularity, where joint 4 runs out of range).
    """
    narrow = orientations.kind == "ball"
    flips = (BRANCH[2],) if narrow else (BRANCH[2], -BRANCH[2])
    for wrist in flips:  # the narrow range as the first releases drew it: no reference
        theta, valid = pose_ik(T06, *ARM_CONFIGURATION, wrist, reference=None if narrow else READY)
        if valid:
            return theta
    return None


def sample_grasp_pose(
    rng: np.random.Generator,
    wrist_box: BoxWorkspace,
    base: np.ndarray,
    orientations: OrientationRange = NARROW,
) -> tuple[np.ndarray, np.ndarray]:
    """One object pose (4, 4, world) and the joints (6,) that grasp it (:func:`grasp_joints`).

    The wrist centre is drawn uniformly from ``wrist_box`` (world), the orientation from
    ``orientations`` (:meth:`OrientationRange.sample`); a draw that no allowed branch reaches
    with every joint in range is drawn again. ``base``: world position of frame 0.
    """
    from models.puma560.inverse import D6

    while True:
        wrist = wrist_box.sample(rng, 1)[0]
        R = orientations.sample(rng)
        tool = wrist + D6 * R[:, 2]
        theta = grasp_joints(homogeneous(R, tool - base), orientations)
        if theta is not None:
            return homogeneous(R, tool), theta


#: Objects drawn to find a range's joint box (:func:`task_joint_box`).
TASK_BOX_OBJECTS = 4096
#: The box's objects come from their own generator, never a run's stream.
_TASK_BOX_SEED = np.random.SeedSequence(560, spawn_key=(9,))


@lru_cache(maxsize=16)
def _joint_box(orientations: OrientationRange) -> tuple[tuple[float, ...], tuple[float, ...]]:
    from models.puma560 import BASE_POS, WORKSPACE

    rng = np.random.Generator(np.random.PCG64(_TASK_BOX_SEED))
    joints = np.array(
        [
            sample_grasp_pose(rng, WORKSPACE, BASE_POS, orientations)[1]
            for _ in range(TASK_BOX_OBJECTS)
        ]
    )  # tuples below: the cached box cannot be changed through a caller's array
    return tuple(joints.min(axis=0).tolist()), tuple(joints.max(axis=0).tolist())


def task_joint_box(orientations: OrientationRange) -> tuple[np.ndarray, np.ndarray]:
    """The joint box (6,), (6,) rad of the grasp task with ``orientations``: the smallest box
    holding the joints that grasp :data:`TASK_BOX_OBJECTS` objects of the reach workspace and
    the range (inside the joint ranges, as those joints are). Commands inside it keep the hand
    near where objects are: a uniformly random one leaves the hand in both cameras' rendered
    views 73 % of the time, against 27 % over the whole joint ranges
    (docs/envs/PumaGrasp-v0.md). Computed once per range and process."""
    low, high = _joint_box(orientations)
    return np.array(low), np.array(high)


def nearest_pose_ik(
    goal: np.ndarray, current: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> tuple[np.ndarray, bool]:
    """The closed-form joints (6,) for the pose ``goal`` (4, 4, frame 0): of the eight branches
    (:func:`~models.puma560.inverse.pose_ik_all`) with every joint in [lower, upper], the one
    nearest ``current`` (6,); of all eight if none is, and then False."""
    thetas, valid = pose_ik_all(goal)  # (8, 6), (8,)
    valid &= np.all((thetas >= lower) & (thetas <= upper), axis=-1)
    distance = np.linalg.norm(thetas - current, axis=-1)
    candidates = np.flatnonzero(valid) if valid.any() else np.arange(len(thetas))
    best = candidates[np.argmin(distance[candidates])]
    return thetas[best], bool(valid.any())


def tcp_frame(theta: np.ndarray) -> np.ndarray:
    """Frame 6 (site ``tcp``) in the base frame, (..., 4, 4), of joint angles (..., 6) rad."""
    return frames(theta)[6]


def grasp_task() -> GraspTask:
    """The PUMA's :class:`~models.grasp_task.GraspTask`: frame 6 (site ``tcp``), the closed-form
    pose IK, objects of :func:`sample_grasp_pose` in the orientation ranges (default
    :data:`WIDE`), the joint box :func:`task_joint_box`."""
    return GraspTask(
        lower=DH.lower.copy(),
        upper=DH.upper.copy(),
        ready=READY.copy(),
        base=BASE_POS.copy(),
        forward=tcp_frame,  # a module function: envs pickle (AsyncVectorEnv)
        jacobian=jacobian,
        pose_ik=nearest_pose_ik,
        sample=sample_grasp_pose,
        joint_box=task_joint_box,
        default_orientations=WIDE,
        parse_orientations=OrientationRange.parse,
    )
