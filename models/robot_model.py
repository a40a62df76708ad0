"""What the models layer knows of a robot: its kinematics, its reach and its target workspace.

Each robot's package ``models/<robot>/`` defines one :class:`RobotModel` as ``MODEL`` in its
``__init__.py``; :func:`robot_model` finds it by the folder's name. Everything below the envs
(the learners' exact baselines, the analyses) reads a robot through it, never by testing its
name; ``envs.robots.ROBOTS`` adds what the environments need.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from models import UnknownModelError, available_models
from models.arms import ArmKinematics
from models.chain import RobotChain
from models.grasp_task import GraspTask
from models.workspace import Workspace


@dataclass(frozen=True)
class RobotModel:
    """One robot's kinematics.

    Attributes:
        name: the robot's folder under ``models/`` (and its key in ``envs.robots.ROBOTS``).
        reach: the arm's reach (m): errors are also given in % of it.
        workspace: where reach targets are drawn (world, m).
        arms: controlled joints -> a factory of the sensed point's kinematics; the factory takes
            an arm configuration (the PUMA's of Brause Fig. 5c; robots with one branch ignore
            it), e.g. ``{3: wrist, 6: tool}``.
        chain: the chain of every kinematic parameter from the base to the tool point, for the
            kinematic-accuracy analysis (``models.analyses.nemecek_accuracy``); None: no such
            analysis for this robot.
        grasp: the pose task's kinematics, object poses and IK, for a robot that offers the
            task (:class:`~models.grasp_task.GraspTask`); None: no pose task.
    """

    name: str
    reach: float
    workspace: Workspace
    arms: Mapping[int, Callable[[str], ArmKinematics]]
    chain: Callable[[], RobotChain] | None = None
    grasp: GraspTask | None = None

    @property
    def joint_options(self) -> tuple[int, ...]:
        """The numbers of controlled joints that have kinematics, ascending."""
        return tuple(sorted(self.arms))

    def arm(self, joints: int, configuration: str = "right-above") -> ArmKinematics:
        """The kinematics of the sensed point with ``joints`` controlled joints."""
        if isinstance(joints, bool) or joints not in self.arms:
            valid = ", ".join(map(str, self.joint_options))
            raise ValueError(
                f"no kinematics for robot {self.name!r} with {joints!r} joints; valid for "
                f"{self.name}: {valid} joints"
            )
        return self.arms[joints](configuration)


def robot_model(name: str) -> RobotModel:
    """The ``MODEL`` of package ``models.<name>``; UnknownModelError listing the robots that
    have a folder, or naming what the folder lacks."""
    if not isinstance(name, str) or name not in available_models():
        raise UnknownModelError(
            f"no robot model named {name!r}; available models: {', '.join(available_models())}"
        )
    package = importlib.import_module(f"models.{name}")
    model = getattr(package, "MODEL", None)
    if not isinstance(model, RobotModel) or model.name != name:
        raise UnknownModelError(
            f"models/{name}/__init__.py must define MODEL = RobotModel(name={name!r}, ...) "
            "(models.robot_model.RobotModel); see docs/layout.md, 'Adding a robot'"
        )
    return model
