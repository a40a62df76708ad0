"""What the reach environment needs to know about each robot."""

from __future__ import annotations

from dataclasses import dataclass

from models import puma560, riacs
from models.workspace import Workspace

#: Width : height of the sensing images of both scenes (320 x 240 by default).
CAMERA_ASPECT = (4, 3)


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
    """

    model: str
    reach: float
    workspace: Workspace
    sensed: dict[int, str]
    markers: dict[int, str]
    image_aspect: tuple[int, int] = CAMERA_ASPECT

    @property
    def joint_options(self) -> tuple[int, ...]:
        return tuple(sorted(self.sensed))


ROBOTS: dict[str, RobotSpec] = {
    "puma560": RobotSpec(
        model="puma560",
        reach=puma560.ARM_REACH,
        workspace=puma560.WORKSPACE,
        sensed={3: "wrist_center", 6: "tcp"},
        markers={3: "marker_wrist", 6: "marker_tcp"},
    ),
    "riacs": RobotSpec(
        model="riacs",
        reach=riacs.ARM_REACH,
        workspace=riacs.WORKSPACE,
        sensed={3: "tcp"},
        markers={3: "marker_tcp"},
    ),
}
