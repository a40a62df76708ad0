"""The robot registry: :data:`ROBOTS`, one :class:`RobotSpec` per robot, which the envs, their
registration, the perturbations, the figures, the sweeps, the benchmarks and the demo read.

The kinematics (reach, workspace, the exact controllers' arms, the accuracy chain) are the robot's
own package's (``models/<robot>/``, its :class:`~models.robot_model.RobotModel`); a spec adds
what the envs need: the scene's sites and markers, the env ids, names and settings. Adding a
robot: ``docs/layout.md``, "Adding a robot".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import models
from envs.sensing.marker_detection import (
    GRASP_HAND,
    GRASP_OBJECT,
    GREEN_EFFECTOR,
    RED_TARGET,
    MarkerColour,
)
from models.marker_frame import HAND_COLOURS, MARKER_COLOURS
from models.robot_model import RobotModel, robot_model
from models.workspace import Workspace

if TYPE_CHECKING:
    import mujoco

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
        ready_key: the keyframe of the task's taught pose, where a learner's joints start.
        learn_in_action_box: a learner's joint ranges are the env's action box (a generated
            arm's grasp task: its joints turn ±360°, and a map whose commands the env clipped
            into the task's box learned from commands that were never made); else the joint
            ranges (the PUMA's maps, as measured).
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
    ready_key: str = "ready"
    learn_in_action_box: bool = False

    @property
    def geoms(self) -> tuple[str, ...]:
        """Every geom this task draws that another task of the robot may hide."""
        return (*self.effector, *self.target, *self.drawn)


#: The PUMA's grasp task (``PumaGrasp-v0``): three markers on the hand, three on the object.
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


#: The grasp task of an arm generated from a DH table with a ``[grasp]`` section
#: (``models/dh_mjcf.py`` writes its hand, ``scene_grasp.xml`` and the keyframe ``grasp_ready``):
#: the PUMA's markers, without its gripper and the object's handle; the arm starts every episode
#: at ``home``.
GENERATED_GRASP = MarkerSet(
    scene="scene_grasp.xml",
    site="tcp",
    effector=PUMA_GRASP.effector,
    target=PUMA_GRASP.target,
    drawn=("hand_crossbar", "hand_post", "object_crossbar", "object_post"),
    target_body="object",
    effector_colours=GRASP_HAND,
    target_colours=GRASP_OBJECT,
    target_outline=True,
    ready_key="grasp_ready",
    learn_in_action_box=True,
)


class RobotSpecError(ValueError):
    """A robot entry that does not fit its model folder or the other entries."""


@dataclass(frozen=True)
class RobotSpec:
    """One robot: its model folder and what its envs, figures, sweeps and the demo need.

    Attributes:
        model: folder name under ``models/`` (= its key in :data:`ROBOTS`); its package's
            ``MODEL`` (the spec's ``kinematics``) gives the reach, the workspace and the
            arms' kinematics.
        title: the arm's name in figure titles ("PUMA 560").
        short: the robot's word in a sweep grid (``robot=puma``) and the demo's run folders.
        reach_env: the Gymnasium id of its reach env (``envs.reach.ReachEnv``), registered by
            :func:`envs.register_robot`.
        sensed: site whose position the effector marker shows, by number of controlled joints.
        markers: green marker geom at each of those sites.
        tool_axes: per sensed site, the outward direction (unit, in the site's body frame) along
            which a perturbation's ``tool`` moves it (a longer tool, a re-attached marker).
        image_aspect: (width, height) ratio of the sensing images that the scene's cameras are
            made for (RIACS: their ``sensorsize``; PUMA: the ``fovy`` margin around the
            workspace is set for it); sensing images of another shape are refused.
        magnify: the arm is small in its cameras' images: films and the demo's scene images
            magnify the marker's neighbourhood.
        grasp: the grasp task's markers, for a robot whose model offers the task (its
            ``MODEL.grasp``, :class:`~models.grasp_task.GraspTask`, which the grasp env
            ``envs.grasp.GraspEnv`` is built on).
        grasp_env: the Gymnasium id of that grasp task's env; grasp_short: its word in a sweep
            grid.
        reach: the arm's reach (m), for errors in % of it; workspace: where reach targets are
            drawn (world, m). Both are the model's unless given (a test narrows the workspace).
        default_runs: the programs that run every robot unless told which (the demo, the docs
            media, sensing accuracy, adaptation, the RL comparison, the env benchmark) run this
            one too; the arms generated from DH tables are left out of them (``--env`` and the
            sweep grid take them).
        swivel_joints: for a redundant arm, the joints whose frame origins (DH chain) are its
            shoulder, elbow and wrist: the redundancy study's swivel angle
            (:mod:`envs.studies.redundancy`); None where it is not measured.
    """

    model: str
    title: str
    short: str
    reach_env: str
    sensed: dict[int, str]
    markers: dict[int, str]
    tool_axes: dict[str, tuple[float, float, float]]
    image_aspect: tuple[int, int] = CAMERA_ASPECT
    magnify: bool = False
    grasp: MarkerSet | None = None
    grasp_env: str | None = None
    grasp_short: str = "grasp"
    reach: float = None  # type: ignore[assignment]  # the model's unless given
    workspace: Workspace = None  # type: ignore[assignment]  # the model's unless given
    default_runs: bool = True
    swivel_joints: tuple[int, int, int] | None = None
    #: The robot's model, read once from its folder's package.
    kinematics: RobotModel = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        model = self._robot_model()
        object.__setattr__(self, "kinematics", model)
        if self.reach is None:
            object.__setattr__(self, "reach", model.reach)
        if self.workspace is None:
            object.__setattr__(self, "workspace", model.workspace)
        if set(self.markers) != set(self.sensed):
            raise RobotSpecError(
                f"robot {self.model!r}: markers are given for {sorted(self.markers)} joints and "
                f"sensed sites for {sorted(self.sensed)}; give both for the same joint counts"
            )
        missing = sorted(set(self.sensed.values()) - set(self.tool_axes))
        if missing:
            raise RobotSpecError(
                f"robot {self.model!r}: no tool axis for sensed site(s) {missing}; add them to "
                "tool_axes (the direction a perturbation's tool moves the site)"
            )
        for site, axis in self.tool_axes.items():
            if len(axis) != 3 or not math.isclose(math.hypot(*axis), 1.0, abs_tol=1e-12):
                raise RobotSpecError(
                    f"robot {self.model!r}: tool axis of {site!r} must be a unit vector "
                    f"(x, y, z), got {axis!r}"
                )
        if (self.grasp is None) != (self.grasp_env is None):
            raise RobotSpecError(
                f"robot {self.model!r}: give the grasp task's markers (grasp) and its env id "
                "(grasp_env) together"
            )
        if self.grasp is not None and model.grasp is None:
            raise RobotSpecError(
                f"robot {self.model!r}: grasp markers are given, but models/{self.model}/ has no "
                "pose task (MODEL.grasp; a DH table's [grasp] section gives one)"
            )

    def _robot_model(self) -> RobotModel:
        """The kinematics: the model folder's ``MODEL`` (a spec built at run time, such as
        ``ArmReach-v0``'s of a user's MJCF, gives its own)."""
        return robot_model(self.model)

    def load_model(self, scene_file: str = "scene.xml") -> mujoco.MjModel:
        """Compile a scene of the robot's folder (``scene.xml``, ``scene_grasp.xml``)."""
        return models.load_model(self.model, scene_file=scene_file)

    @property
    def joint_options(self) -> tuple[int, ...]:
        return tuple(sorted(self.sensed))

    @property
    def sweep_names(self) -> dict[str, str]:
        """This robot's words in a sweep grid -> their env ids."""
        names = {self.short: self.reach_env}
        if self.grasp_env is not None:
            names[self.grasp_short] = self.grasp_env
        return names

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
    "riacs": RobotSpec(
        model="riacs",
        title="RIACS 3-DOF arm",
        short="riacs",
        reach_env="RiacsReach-v0",
        sensed={3: "tcp"},
        markers={3: "marker_tcp"},
        # Along link 2, from the elbow (body origin) to the tcp.
        tool_axes={"tcp": (0.0, -1.0, 0.0)},
        magnify=True,
    ),
    "puma560": RobotSpec(
        model="puma560",
        title="PUMA 560",
        short="puma",
        reach_env="PumaReach-v0",
        sensed={3: "wrist_center", 6: "tcp"},
        markers={3: "marker_wrist", 6: "marker_tcp"},
        tool_axes={
            # Along the forearm (link 4's z = frame 4's -y), which is link 5's -y while joint 5
            # is at its home angle 0 (the PUMA with 3 controlled joints holds joints 4-6 at home).
            "wrist_center": (0.0, -1.0, 0.0),
            "tcp": (0.0, 0.0, 1.0),  # along the tool axis z6
        },
        grasp=PUMA_GRASP,
        grasp_env="PumaGrasp-v0",
    ),
    # Arms generated from their DH tables (models/<robot>/dh.toml, visuomotor-make-arm).
    "ur5e": RobotSpec(
        model="ur5e",
        title="UR5e-type arm",
        short="ur5e",
        reach_env="Ur5eReach-v0",
        sensed={3: "tcp", 6: "tcp"},
        markers={3: "marker_tcp", 6: "marker_tcp"},
        tool_axes={"tcp": (0.0, 0.0, 1.0)},  # the flange's z (the site's frame is link6's)
        grasp=GENERATED_GRASP,
        grasp_env="Ur5eGrasp-v0",
        grasp_short="ur5e_grasp",
        default_runs=False,
    ),
    "panda": RobotSpec(
        model="panda",
        title="Franka-Panda-type arm",
        short="panda",
        reach_env="PandaReach-v0",
        sensed={7: "tcp"},
        markers={7: "marker_tcp"},
        tool_axes={"tcp": (0.0, 0.0, 1.0)},  # the flange's z (the site's frame is link7's)
        grasp=GENERATED_GRASP,
        grasp_env="PandaGrasp-v0",
        grasp_short="panda_grasp",
        default_runs=False,
        swivel_joints=(2, 4, 6),  # shoulder, elbow, wrist: envs/studies/redundancy.py
    ),
}


def robot_spec(robot: str | RobotSpec) -> RobotSpec:
    """The spec of a registry key, or ``robot`` itself if it is a spec (an env built at run time
    from a user's model); ValueError naming the registered robots else."""
    if isinstance(robot, RobotSpec):
        return robot
    if not isinstance(robot, str) or robot not in ROBOTS:
        raise ValueError(f"unknown robot {robot!r}; valid robots: {', '.join(ROBOTS)}")
    return ROBOTS[robot]


def check_registry(robots: dict[str, RobotSpec]) -> None:
    """RobotSpecError unless every entry sits under its model's name, has a model folder whose
    kinematics cover its joint counts, and no two entries share an env id or a sweep word."""
    owners: dict[str, dict[str, str]] = {"env id": {}, "sweep word": {}}
    for key, spec in robots.items():
        if key != spec.model:
            raise RobotSpecError(f"ROBOTS[{key!r}] is the spec of {spec.model!r}; key it so")
        missing = sorted(set(spec.joint_options) - set(spec.kinematics.joint_options))
        if missing:
            raise RobotSpecError(
                f"robot {key!r} senses with {missing} joints, but models/{key}/ has no "
                f"kinematics for them (its MODEL.arms: {list(spec.kinematics.joint_options)})"
            )
        for kind, names in (
            ("env id", spec.sweep_names.values()),
            ("sweep word", spec.sweep_names),
        ):
            for name in names:
                if name in owners[kind]:
                    raise RobotSpecError(
                        f"robots {owners[kind][name]!r} and {key!r} both use the {kind} {name!r}"
                    )
                owners[kind][name] = key


def reach_env_ids() -> tuple[str, ...]:
    """Every robot's reach env id, in registry order (``RiacsReach-v0``, ``PumaReach-v0``)."""
    return tuple(spec.reach_env for spec in ROBOTS.values())


def default_reach_env_ids() -> tuple[str, ...]:
    """The reach env ids of the robots with :attr:`RobotSpec.default_runs`, in registry order."""
    return tuple(spec.reach_env for spec in ROBOTS.values() if spec.default_runs)


def grasp_env_ids() -> tuple[str, ...]:
    """Every robot's grasp env id (``PumaGrasp-v0``, ``Ur5eGrasp-v0``)."""
    return tuple(spec.grasp_env for spec in ROBOTS.values() if spec.grasp_env is not None)


def default_grasp_env_ids() -> tuple[str, ...]:
    """The grasp env ids of the robots with :attr:`RobotSpec.default_runs` (``PumaGrasp-v0``)."""
    return tuple(
        spec.grasp_env
        for spec in ROBOTS.values()
        if spec.grasp_env is not None and spec.default_runs
    )


def robot_of_env(env_id: str) -> str:
    """The registry key of the robot whose reach or grasp env is ``env_id``; ValueError naming
    the registered ids else."""
    for name, spec in ROBOTS.items():
        if env_id in (spec.reach_env, spec.grasp_env):
            return name
    valid = ", ".join((*reach_env_ids(), *grasp_env_ids()))
    raise ValueError(f"no robot has the env {env_id!r}; registered: {valid}")


def sweep_names() -> dict[str, str]:
    """Every robot's words in a sweep grid -> their env ids (``riacs``, ``puma``, ``grasp``)."""
    return {name: env for spec in ROBOTS.values() for name, env in spec.sweep_names.items()}


check_registry(ROBOTS)
