"""The simulated arm scene that the environments share: what the simulation can tell.

In the spirit of dm_control's split of *Physics* from *Task*, :class:`ArmScene` holds the MuJoCo
model and data of a robot's ``scene.xml``, the controlled joints, the sensed point with its marker,
and the stereo rig that sees them, and answers questions about them through public methods. The
environments (:class:`envs.reach.ReachEnv`, :class:`envs.track.PumaTrackEnv`) add the task:
spaces, reset, step, reward. Studies, benchmarks and tests use the same methods instead of
reaching into an env's private attributes.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, fields

import gymnasium as gym
import mujoco
import numpy as np

from envs.robots import MarkerSet, RobotSpec, robot_spec
from envs.sensing.foveated import FoveatedSensing
from envs.sensing.stereo import StereoRig
from envs.sizes import check_image_size

#: Default sensing image size, pixels.
IMAGE_WIDTH, IMAGE_HEIGHT = 320, 240
#: Geom group that no camera or viewer of the project draws: markers of other joint options,
#: and the geoms of the robot's other tasks (:attr:`RobotSpec.task_geoms`).
HIDDEN_GROUP = 5
#: The state a reset restores: what ``mj_step`` reads (time, positions, velocities, controls,
#: mocap poses, warm start, ...), MuJoCo's documented integration state.
INTEGRATION_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


@dataclass(frozen=True)
class WorkCounts:
    """What a scene has done since it was made (:meth:`ArmScene.work_counts`); the difference
    of two counts is what was done between them."""

    renders: int  # the sensing cameras' renderings, one read-back each
    views: int  # camera views (whole images or windows) drawn in them
    physics_steps: int  # mj_step calls of servo moves
    fallbacks: int  # foveated sensing calls that rendered the whole images

    def __sub__(self, other: WorkCounts) -> WorkCounts:
        return WorkCounts(*(getattr(self, f.name) - getattr(other, f.name) for f in fields(self)))


class ArmScene(gym.Env):
    """A robot arm in its scene with two sensing cameras, the base of the arm environments.

    Args:
        robot: a key of :data:`envs.robots.ROBOTS` (or a spec built at run time).
        joints: number of controlled joints (``joint1``..``joint<joints>``); they decide the
            sensed point (:attr:`RobotSpec.sensed`) and its green marker, the only one drawn.
        width, height: sensing image size in pixels, in the cameras' aspect ratio
            (:attr:`RobotSpec.image_aspect`).
        markers: the task's scene, sensed site and marker spheres (default: the reach task's,
            :meth:`RobotSpec.reach_markers`); the geoms of the robot's other tasks are hidden.
    Raises:
        ImageSizeError: a size that is not whole pixels, too small, or of another aspect ratio.

    The data starts at the keyframe ``home``, with every position computed. Renderers start at
    the first rendering (GL resources are not pickled).
    """

    def __init__(
        self,
        robot: str | RobotSpec,
        joints: int,
        width: int,
        height: int,
        markers: MarkerSet | None = None,
    ) -> None:
        self.robot_spec: RobotSpec = robot_spec(robot)
        width, height = check_image_size(width, height, self.robot_spec.image_aspect)
        self.image_width, self.image_height = width, height
        self.markers = self.robot_spec.reach_markers(joints) if markers is None else markers
        self.model = self.robot_spec.load_model(self.markers.scene)
        self.data = mujoco.MjData(self.model)
        self._home = self.model.key(self.markers.start_key).id  # where every episode starts
        self._joint_ids = np.array([self.model.joint(f"joint{i + 1}").id for i in range(joints)])
        self._qpos_ids = self.model.jnt_qposadr[self._joint_ids]
        self._qpos = as_slice(self._qpos_ids)
        self._dof_ids = self.model.jnt_dofadr[self._joint_ids]
        self.joint_lower = self.model.jnt_range[self._joint_ids, 0].copy()  # rad
        self.joint_upper = self.model.jnt_range[self._joint_ids, 1].copy()  # rad
        self._site = self.model.site(self.markers.site).id
        hide_geoms(self.model, self.robot_spec.task_geoms - set(self.markers.geoms))
        self._effector_geoms = np.array([self.model.geom(g).id for g in self.markers.effector])
        self._target_geoms = np.array([self.model.geom(g).id for g in self.markers.target])
        self._target_mocap = int(
            self.model.body_mocapid[self.model.body(self.markers.target_body).id]
        )
        self._marker_radius = float(self.model.geom_size[self._effector_geoms[0]][0])  # m
        self._target_radius = float(self.model.geom_size[self._target_geoms[0]][0])  # m
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._home)
        self._start_state = np.empty(mujoco.mj_stateSize(self.model, INTEGRATION_STATE))
        mujoco.mj_getState(self.model, self.data, self._start_state, INTEGRATION_STATE)
        mujoco.mj_forward(self.model, self.data)
        self.stereo = StereoRig(self.model, self.data, height, width)
        self._fovea: FoveatedSensing | None = None
        self._was_reset = False  # step() needs an episode: reset() first
        self.physics_steps = 0  # mj_step calls of the moves (the environments count them)

    # -- episodes ------------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Seed ``np_random`` (Gymnasium's rule) and allow ``step``; the environments draw the
        episode after this."""
        super().reset(seed=seed)
        self._was_reset = True

    def restore_start(self) -> None:
        """Put the simulation back where ``mj_resetDataKeyframe`` of the start keyframe puts it:
        its integration state (``mjSTATE_INTEGRATION``, everything ``mj_step`` reads), in one
        copy; positions and the other derived quantities follow at the next forward pass."""
        mujoco.mj_setState(self.model, self.data, self._start_state, INTEGRATION_STATE)

    def require_reset(self) -> None:
        """Raise ``gymnasium.error.ResetNeeded`` (what Gymnasium's ``OrderEnforcing`` wrapper
        raises) if the env has not been reset yet: ``step`` has no episode to act in."""
        if not self._was_reset:
            raise gym.error.ResetNeeded("step() before reset(): call env.reset() first")

    # -- the controlled joints -----------------------------------------------------------------

    @property
    def qpos_ids(self) -> np.ndarray:
        """(J,) indices of the controlled joints in ``data.qpos``."""
        return self._qpos_ids.copy()

    def set_joints(self, q: np.ndarray, data: mujoco.MjData | None = None) -> None:
        """Put the controlled joints at ``q`` (J,) rad, at rest, and compute the positions
        (``mj_kinematics`` and ``mj_camlight``: what sensing and rendering read).

        Args:
            data: another MjData of this scene's model (default: the scene's own).
        """
        data = self.data if data is None else data
        data.qpos[self._qpos] = q
        data.qvel[:] = 0.0
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_camlight(self.model, data)

    # -- the sensed point ----------------------------------------------------------------------

    def sensed_point(self, data: mujoco.MjData | None = None) -> np.ndarray:
        """World position (3,) m of the sensed point (the marker's centre), a copy."""
        return (self.data if data is None else data).site_xpos[self._site].copy()

    def sensed_point_jacobian(self, data: mujoco.MjData | None = None) -> np.ndarray:
        """∂(sensed point)/∂(controlled joints), (3, J) m/rad, at the positions in ``data``
        (after :meth:`set_joints`)."""
        data = self.data if data is None else data
        jac = np.zeros((3, self.model.nv))
        mujoco.mj_comPos(self.model, data)  # the Jacobian needs cdof
        mujoco.mj_jacSite(self.model, data, jac, None, self._site)
        return jac[:, self._dof_ids]

    @property
    def sensed_site_id(self) -> int:
        """MuJoCo id of the sensed site."""
        return self._site

    @property
    def effector_geom_ids(self) -> np.ndarray:
        """MuJoCo ids (M,) of the effector's marker spheres, in the task's marker order."""
        return self._effector_geoms.copy()

    @property
    def target_geom_ids(self) -> np.ndarray:
        """MuJoCo ids (M,) of the target's marker spheres, in the task's marker order."""
        return self._target_geoms.copy()

    @property
    def target_mocap_id(self) -> int:
        """Index in ``data.mocap_pos`` of the target's mocap body."""
        return self._target_mocap

    @property
    def marker_radius(self) -> float:
        """Radius (m) of the green marker sphere at the sensed point."""
        return self._marker_radius

    @property
    def target_radius(self) -> float:
        """Radius (m) of the red target sphere."""
        return self._target_radius

    # -- the cameras ---------------------------------------------------------------------------

    @property
    def fovea(self) -> FoveatedSensing:
        """Foveated sensing through this scene's stereo rig (made at the first use, then kept:
        ``fovea.fallbacks`` counts its calls that rendered the whole images)."""
        if self._fovea is None:
            self._fovea = FoveatedSensing(self.stereo)
        return self._fovea

    def work_counts(self) -> WorkCounts:
        """The sensing renderings, the views drawn in them, the physics steps and the foveated
        fallbacks so far (counters kept as the work is done; reading them costs nothing)."""
        renders, views = self.stereo.renders
        fallbacks = 0 if self._fovea is None else self._fovea.fallbacks
        return WorkCounts(renders, views, self.physics_steps, fallbacks)

    def close(self) -> None:
        self.stereo.close()


def hide_geoms(model: mujoco.MjModel, names: Iterable[str]) -> None:
    """Move the named geoms into HIDDEN_GROUP, which no camera or viewer draws; names the
    model does not have are skipped (the grasp task's object is only in its own scene)."""
    for name in sorted(names):
        geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if geom >= 0:
            model.geom_group[geom] = HIDDEN_GROUP


def as_slice(ids: np.ndarray) -> slice | np.ndarray:
    """Consecutive indices as a slice (MjData arrays index a slice faster than an index
    array), others unchanged."""
    first = int(ids[0])
    consecutive = ids.tolist() == list(range(first, first + len(ids)))
    return slice(first, first + len(ids)) if consecutive else ids
