"""What the reach environment needs to know about each robot."""

from __future__ import annotations

from dataclasses import dataclass

from envs.sensing.marker_detection import (
    GRASP_HAND,
    GRASP_OBJECT,
    GREEN_EFFECTOR,
    RED_TARGET,
    MarkerColour,
)
from models import puma560, riacs
from models.puma560.grasp import HAND_COLOURS, MARKER_COLOURS
from models.workspace import Workspace

#: Width : height of the sensing images of both scenes (320 x 240 by default).
CAMERA_ASPECT = (4, 3)


@dataclass(frozen=True)
class MarkerSet:
    """What one task senses and draws in a robot's scene.

    Attributes:
        scene: the scene file in the robot's folder (``scene.xml``, ``scene_grasp.xml``).
        site: the sensed point: the effector's origin (a MuJoCo site).
        effector: marker sphere geoms on the arm, sensed after every move (group 4).
        target: marker sphere geoms of the target, sensed at reset (group 1).
        drawn: other geoms that this task draws and the robot's other tasks hide (the
            gripper, marker posts, the object's handle).
        target_body: the mocap body that reset places.
        effector_colours, target_colours: the colour of each marker sphere, in their order.
        target_outline: rendered sensing finds the target's markers from their outlines
            fitted with their radius, as the arm's (a handle or a post may hide part of one),
            instead of from their blobs (the reach task's lone target sphere).
        start_key: the keyframe the arm starts every episode from.
    """

    scene: str
    site: str
    effector: tuple[str, ...]
    target: tuple[str, ...]
    drawn: tuple[str, ...] = ()
    target_body: str = "target"
    effector_colours: tuple[MarkerColour, ...] = (GREEN_EFFECTOR,)
    target_colours: tuple[MarkerColour, ...] = (RED_TARGET,)
    target_outline: bool = False
    start_key: str = "home"

    @property
    def geoms(self) -> tuple[str, ...]:
        """Every geom this task draws that another task of the robot may hide."""
        return (*self.effector, *self.target, *self.drawn)


#: The PUMA's pose task (``PumaGrasp-v0``): three markers on the hand, three on the object.
PUMA_GRASP = MarkerSet(
    scene="scene_grasp.xml",
    site="tcp",
    effector=tuple(f"hand_marker_{c}" for c in HAND_COLOURS),
    target=tuple(f"object_marker_{c}" for c in MARKER_COLOURS),
    drawn=(
        "gripper_palm",
        "gripper_finger_left",
        "gripper_finger_right",
        "hand_crossbar",
        "hand_post",
        "object_handle",
        "object_crossbar",
        "object_post",
    ),
    target_body="object",
    effector_colours=GRASP_HAND,
    target_colours=GRASP_OBJECT,
    target_outline=True,
    start_key="park",
)


@dataclass(frozen=True)
class RobotSpec:
    """One robot's reach task.

    Attributes:
        model: folder name under ``models/``.
        reach: length used to express errors in % (m).
        workspace: where targets are drawn.
        sensed: site whose position the effector marker shows, by number of controlled joints.
        markers: green marker geom at each of those sites.
        image_aspect: (width, height) ratio of the sensing images that the scene's cameras are
            made for (RIACS: their ``sensorsize``; PUMA: the ``fovy`` margin around the
            workspace is set for it); sensing images of another shape are refused.
        grasp: the pose task's markers, for a robot that has one.
    """

    model: str
    reach: float
    workspace: Workspace
    sensed: dict[int, str]
    markers: dict[int, str]
    image_aspect: tuple[int, int] = CAMERA_ASPECT
    grasp: MarkerSet | None = None

    @property
    def joint_options(self) -> tuple[int, ...]:
        return tuple(sorted(self.sensed))

    def reach_markers(self, joints: int) -> MarkerSet:
        """The reach task's markers with ``joints`` controlled joints: the red target sphere and
        the green marker at the sensed point."""
        return MarkerSet("scene.xml", self.sensed[joints], (self.markers[joints],), ("target",))

    @property
    def task_geoms(self) -> frozenset[str]:
        """Every geom that some task of this robot draws and the others hide."""
        tasks = [self.reach_markers(j) for j in self.joint_options]
        if self.grasp is not None:
            tasks.append(self.grasp)
        return frozenset(g for task in tasks for g in task.geoms)


ROBOTS: dict[str, RobotSpec] = {
    "puma560": RobotSpec(
        model="puma560",
        reach=puma560.ARM_REACH,
        workspace=puma560.WORKSPACE,
        sensed={3: "wrist_center", 6: "tcp"},
        markers={3: "marker_wrist", 6: "marker_tcp"},
        grasp=PUMA_GRASP,
    ),
    "riacs": RobotSpec(
        model="riacs",
        reach=riacs.ARM_REACH,
        workspace=riacs.WORKSPACE,
        sensed={3: "tcp"},
        markers={3: "marker_tcp"},
    ),
}
