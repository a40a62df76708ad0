"""What the pose (grasp) task needs of an arm: its tool frame's kinematics, its exact pose IK,
how objects are drawn and the joint box that grasps them.

Each robot that offers the task gives one :class:`GraspTask` as its
:attr:`~models.robot_model.RobotModel.grasp`: the PUMA's closed form and orientation ranges
(``models/puma560/grasp.py``), an arm generated from a DH table with a ``[grasp]`` section its
numerical pose IK and the hand's poses over a joint box (``models/dh_grasp.py``). Both hands
carry the marker frame of :mod:`models.marker_frame` at their tool frame (site ``tcp``).

Poses of the tool frame given to or returned by ``forward``, ``jacobian`` and ``pose_ik`` are in
frame 0: the world's axes, its origin at ``base``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from models.workspace import BoxWorkspace

#: (rng, box, base, orientations) -> (object pose (4, 4), world; the joints (J,) that grasp it).
Sampler = Callable[
    [np.random.Generator, BoxWorkspace, np.ndarray, Any], tuple[np.ndarray, np.ndarray]
]


@dataclass(frozen=True)
class GraspTask:
    """One arm's pose task.

    Attributes:
        lower, upper: joint ranges (J,), rad.
        ready: the taught pose (J,), rad, that the pose floors start from.
        base: world position (3,) of frame 0, m.
        forward: joints (J,) -> the tool frame's pose (4, 4) in frame 0.
        jacobian: joints (J,) -> its geometric Jacobian (6, J) in frame 0: linear (m/rad) over
            angular (rad/rad) rows.
        pose_ik: (goal (4, 4) frame 0, current joints (J,), lower (J,), upper (J,)) -> joints
            (J,) inside [lower, upper] that put the tool frame at ``goal`` (the solution nearest
            ``current`` the method finds), and whether they reach it.
        sample: (rng, box, base, orientations) -> one object pose (4, 4, world) drawn with
            ``rng`` and the joints (J,) that grasp it; ``box`` is the reach task's workspace
            and ``base`` frame 0, both where a perturbation moved them (world, m).
        joint_box: orientations -> the task's joint box (J,), (J,) rad, which holds the joints
            of every object ``sample`` draws for them.
        default_orientations: the objects' orientation range an env takes by default (the
            PUMA's :class:`~models.puma560.grasp.OrientationRange`), or None for an arm whose
            objects come from its joint box alone (it takes no other range).
        parse_orientations: a range's spelling (or the range) -> the range; ValueError naming
            the valid spellings.
    """

    lower: np.ndarray
    upper: np.ndarray
    ready: np.ndarray
    base: np.ndarray
    forward: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    pose_ik: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, bool]]
    sample: Sampler
    joint_box: Callable[[Any], tuple[np.ndarray, np.ndarray]]
    default_orientations: Any = None
    parse_orientations: Callable[[Any], Any] | None = None

    @property
    def n_joints(self) -> int:
        return len(self.lower)

    def orientations(self, spelled: Any) -> Any:
        """The range ``spelled`` names (None: :attr:`default_orientations`); ValueError if this
        arm draws its objects from its joint box alone and a range is given."""
        if spelled is None:
            return self.default_orientations
        if self.parse_orientations is None:
            raise ValueError(
                f"orientations {spelled!r}: this arm's objects are its hand's poses over its "
                "joint box (the [grasp] section of its DH table); leave orientations out"
            )
        return self.parse_orientations(spelled)
