"""What the reach environment needs to know about each robot."""

from __future__ import annotations

from dataclasses import dataclass

from models import puma560, riacs
from models.workspace import Workspace


@dataclass(frozen=True)
class RobotSpec:
    """One robot's reach task.

    Attributes:
        model: folder name under ``models/``.
        reach: length used to express errors in % (m).
        workspace: where targets are drawn.
        sensed: site whose position the effector marker shows, by number of controlled joints.
        markers: green marker geom at each of those sites.
    """

    model: str
    reach: float
    workspace: Workspace
    sensed: dict[int, str]
    markers: dict[int, str]

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
