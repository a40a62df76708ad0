"""ArmReach-v0: the reach task on a user's own MJCF (a file or a ``mujoco.MjSpec``).

The model is loaded through ``mujoco.MjSpec`` and completed in a copy: the named joints become
``joint1``..``jointN`` with position servos of the same names (the model's actuators on them
are removed; gravity is compensated on every body); a green marker sphere (group 4) is added
at the effector site; where the model has none, a mocap ``target`` with a red sphere, a light
and the cameras ``cam_left``, ``cam_right`` and ``overview`` (placed as a generated arm's,
:func:`models.dh_mjcf.place_cameras`, about the site's positions over seeded random joint
vectors). Joint ranges are the model's (an unlimited hinge: ±π); home is the keyframe
``home``, else the model's first keyframe, else zeros, clipped into the ranges; the keyframe
``ready`` (where a fresh map's joint vectors and the numerical IK start) puts the site as
near the sampled points' centre as the IK from home gets. Targets are
drawn near the effector's reachable points (:class:`ReachableCloud`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from envs.reach import ReachEnv
from envs.robots import RobotSpec
from models.arms import ArmKinematics
from models.dh_mjcf import SERVO_FREQUENCY, mass_diagonal, place_cameras
from models.numeric_ik import solve_positions
from models.robot_model import RobotModel
from models.workspace import Workspace

#: Random joint vectors whose effector positions frame the cameras and make the target cloud.
SAMPLES = 2000
SAMPLE_SEED = 0
#: m: targets are drawn this close to one of the sampled reachable points.
CLOUD_RADIUS = 0.02
#: m: the added marker's and target's radius, unless given.
MARKER_RADIUS = 0.02
UNLIMITED_RANGE = (-np.pi, np.pi)  # rad, for a hinge the model leaves unlimited
USER_ROBOT = "user_arm"


class UserModelError(ValueError):
    """A user's model that lacks what ArmReach-v0 was told to use."""


@dataclass(frozen=True)
class ReachableCloud(Workspace):
    """Points (world, m) within ``radius`` of a sampled reachable effector position."""

    points: np.ndarray  # (K, 3)
    radius: float = CLOUD_RADIUS

    @cached_property
    def lower(self) -> np.ndarray:  # type: ignore[override]
        return self.points.min(axis=0) - self.radius

    @cached_property
    def upper(self) -> np.ndarray:  # type: ignore[override]
        return self.points.max(axis=0) + self.radius

    def contains(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        d2 = np.sum((p[:, None, :] - self.points[None]) ** 2, axis=-1)  # (N, K)
        return np.min(d2, axis=-1) <= self.radius**2

    def contains_point(self, x: float, y: float, z: float) -> bool:
        return bool(self.contains(np.array([[x, y, z]]))[0])


@dataclass(frozen=True)
class UserRobotSpec(RobotSpec):
    """A :class:`RobotSpec` built at run time from a completed MjSpec and its kinematics."""

    mj_spec: Any = field(default=None, repr=False, compare=False)
    user_kinematics: Any = field(default=None, repr=False, compare=False)

    def _robot_model(self) -> RobotModel:
        return self.user_kinematics

    def load_model(self, scene_file: str = "scene.xml") -> mujoco.MjModel:
        return self.mj_spec.compile()


def _load(robot: str | Path | mujoco.MjSpec) -> mujoco.MjSpec:
    if isinstance(robot, mujoco.MjSpec):
        return robot.copy()
    path = Path(robot)
    if not path.is_file():
        raise UserModelError(f"no MJCF file {path}; give a path to an .xml file or an MjSpec")
    try:
        return mujoco.MjSpec.from_file(str(path))
    except ValueError as error:
        raise UserModelError(f"MuJoCo cannot read {path}: {' '.join(str(error).split())}") from None


def _check_names(spec: mujoco.MjSpec, joints: Sequence[str], site: str) -> None:
    if isinstance(joints, str) or not joints or not all(isinstance(j, str) for j in joints):
        raise UserModelError(f"joints must be a list of joint names, got {joints!r}")
    names = [j.name for j in spec.joints]
    missing = [j for j in joints if j not in names]
    if missing:
        raise UserModelError(
            f"the model has no joint(s) {missing}; its joints: {', '.join(names) or 'none'}"
        )
    if len(set(joints)) != len(joints):
        raise UserModelError(f"joints {list(joints)} name a joint twice")
    for j in joints:
        if spec.joint(j).type not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            raise UserModelError(f"joint {j!r} is not a hinge or slide joint; name 1-DOF joints")
    sites = [s.name for s in spec.sites]
    if site not in sites:
        raise UserModelError(
            f"the model has no site {site!r}; its sites: {', '.join(sites) or 'none'}"
        )


def _home(model: mujoco.MjModel, lower: np.ndarray, upper: np.ndarray, qadr: np.ndarray):
    """Full qpos of home: keyframe 'home', else the first keyframe, else qpos0; the named
    joints clipped into range (zeros where there is no keyframe)."""
    if model.nkey:
        names = [model.key(i).name for i in range(model.nkey)]
        qpos = model.key_qpos[names.index("home") if "home" in names else 0].copy()
    else:
        qpos = model.qpos0.copy()
        qpos[qadr] = 0.0
    qpos[qadr] = np.clip(qpos[qadr], lower, upper)
    return qpos


def complete(
    robot: str | Path | mujoco.MjSpec, joints: Sequence[str], effector_site: str,
    marker_radius: float = MARKER_RADIUS,
) -> tuple[mujoco.MjSpec, np.ndarray]:  # fmt: skip
    """The completed MjSpec (module docstring) and its home qpos; UserModelError naming what is
    missing."""
    spec = _load(robot)
    _check_names(spec, joints, effector_site)
    original = spec.compile()
    ids = np.array([original.joint(j).id for j in joints])
    limited = original.jnt_limited[ids].astype(bool)
    lower = np.where(limited, original.jnt_range[ids, 0], UNLIMITED_RANGE[0])
    upper = np.where(limited, original.jnt_range[ids, 1], UNLIMITED_RANGE[1])
    home = _home(original, lower, upper, original.jnt_qposadr[ids])
    for key in list(spec.keys):
        spec.delete(key)
    driven = set(joints)
    for actuator in list(spec.actuators):
        if actuator.target in driven:
            spec.delete(actuator)
    for other in spec.joints:  # free the names joint1..N for the renamed ones
        if other.name not in driven and other.name.startswith("joint"):
            other.name = f"user_{other.name}"
    for i, name in enumerate(joints):
        joint = spec.joint(name)
        joint.name = f"joint{i + 1}"
        joint.range = [lower[i], upper[i]]
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    for i in range(len(joints)):
        actuator = spec.add_actuator(name=f"joint{i + 1}", target=f"joint{i + 1}")
        actuator.trntype = mujoco.mjtTrn.mjTRN_JOINT
        actuator.set_to_position(kp=1.0)
        actuator.ctrlrange = [lower[i], upper[i]]
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    site = spec.site(effector_site)
    if "marker_effector" not in [g.name for g in spec.geoms]:
        site.parent.add_geom(
            name="marker_effector", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=site.pos,
            size=[marker_radius, 0, 0], group=4, contype=0, conaffinity=0,
            rgba=[0.1, 0.9, 0.1, 1],
        )  # fmt: skip
    if "target" not in [b.name for b in spec.bodies]:
        target = spec.worldbody.add_body(name="target", mocap=True)
        target.add_geom(
            name="target", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[marker_radius, 0, 0],
            group=1, contype=0, conaffinity=0, rgba=[0.9, 0.1, 0.1, 1],
        )  # fmt: skip
    for body in spec.bodies:  # the servos hold poses without a gravity error, as the PUMA's
        body.gravcomp = 1.0
    if not list(spec.lights):
        spec.worldbody.add_light(name="key", pos=[0, 0, 3], dir=[0, 0, -1])
    return spec, home


def _sample_sites(spec: mujoco.MjSpec, home: np.ndarray, n_joints: int, site: str):
    model = spec.compile()
    data = mujoco.MjData(model)
    ids = np.array([model.joint(f"joint{i + 1}").id for i in range(n_joints)])
    qadr = model.jnt_qposadr[ids]
    lower, upper = model.jnt_range[ids, 0], model.jnt_range[ids, 1]
    rng = np.random.default_rng(SAMPLE_SEED)
    points = np.empty((SAMPLES, 3))
    data.qpos[:] = home
    for k, q in enumerate(rng.uniform(lower, upper, size=(SAMPLES, n_joints))):
        data.qpos[qadr] = q
        mujoco.mj_kinematics(model, data)
        points[k] = data.site(site).xpos
    return model, points


def _add_cameras(spec: mujoco.MjSpec, points: np.ndarray) -> None:
    names = {c.name for c in spec.cameras}
    if {"cam_left", "cam_right"} <= names:
        return
    towards = points.mean(axis=0) + np.array([1.0, 0.0, 0.0])  # the pair looks along -x
    for camera in place_cameras(points, towards):
        if camera.name in names:
            continue
        spec.worldbody.add_camera(
            name=camera.name, pos=camera.pos, fovy=camera.fovy_deg,
            quat=_camera_quat(camera.right, camera.up),
        )  # fmt: skip


def _camera_quat(right: np.ndarray, up: np.ndarray) -> np.ndarray:
    R = np.stack([right, up, np.cross(right, up)], axis=1)  # columns: camera x, y, z (back)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, R.flatten())
    return quat


def _set_servos(spec: mujoco.MjSpec, model: mujoco.MjModel, home: np.ndarray, n: int) -> None:
    """kp = I ω², kv = 2 I ω with I each joint's inertia at home, as a generated arm's."""
    inertia = mass_diagonal(model, home)
    for i in range(n):
        dof = model.jnt_dofadr[model.joint(f"joint{i + 1}").id]
        spec.actuator(f"joint{i + 1}").set_to_position(
            kp=inertia[dof] * SERVO_FREQUENCY**2, kv=2 * inertia[dof] * SERVO_FREQUENCY
        )


def _kinematics(model: mujoco.MjModel, home: np.ndarray, n: int, site: str, ready: np.ndarray):
    data = mujoco.MjData(model)
    ids = np.array([model.joint(f"joint{i + 1}").id for i in range(n)])
    qadr, dofs = model.jnt_qposadr[ids], model.jnt_dofadr[ids]
    lower, upper = model.jnt_range[ids, 0].copy(), model.jnt_range[ids, 1].copy()
    site_id = model.site(site).id

    def forward(theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        flat = theta.reshape(-1, n)
        out = np.empty((len(flat), 3))
        for k, q in enumerate(flat):
            data.qpos[:] = home
            data.qpos[qadr] = q
            mujoco.mj_kinematics(model, data)
            out[k] = data.site_xpos[site_id]
        return out.reshape(*theta.shape[:-1], 3)

    def jacobian(theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        flat = theta.reshape(-1, n)
        out = np.empty((len(flat), 3, n))
        jac = np.zeros((3, model.nv))
        for k, q in enumerate(flat):
            data.qpos[:] = home
            data.qpos[qadr] = q
            mujoco.mj_kinematics(model, data)
            mujoco.mj_comPos(model, data)
            mujoco.mj_jacSite(model, data, jac, None, site_id)
            out[k] = jac[:, dofs]
        return out.reshape(*theta.shape[:-1], 3, n)

    def inverse(points: np.ndarray, reference: np.ndarray | None = None):
        p = np.atleast_2d(np.asarray(points, dtype=float))
        start = np.broadcast_to(ready if reference is None else reference, (len(p), n))
        return solve_positions(forward, jacobian, p, start, lower, upper)

    return ArmKinematics(USER_ROBOT, lower, upper, home[qadr].copy(), ready, forward, jacobian,
                         inverse)  # fmt: skip


def user_robot(
    robot: str | Path | mujoco.MjSpec, joints: Sequence[str], effector_site: str
) -> UserRobotSpec:
    """The spec of a user's model for :class:`ArmReachEnv`."""
    spec, home = complete(robot, joints, effector_site)
    n = len(joints)
    model, points = _sample_sites(spec, home, n, effector_site)
    _add_cameras(spec, points)
    _set_servos(spec, model, home, n)
    model = spec.compile()
    qadr = model.jnt_qposadr[[model.joint(f"joint{i + 1}").id for i in range(n)]]
    spec.add_key(name="home", qpos=home, ctrl=home[qadr])
    model = spec.compile()
    start = _kinematics(model, home, n, effector_site, home[qadr].copy())
    ready = start.inverse(points.mean(axis=0)[None], home[qadr][None])[0][0]
    posture = home.copy()
    posture[qadr] = ready
    spec.add_key(name="ready", qpos=posture, ctrl=ready)  # where a fresh map's θ start
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_kinematics(model, data)
    anchor = data.xanchor[model.joint("joint1").id]  # reach: from the first joint's axis
    reach = float(np.max(np.linalg.norm(points - anchor, axis=-1)))
    workspace = ReachableCloud(points)
    arm = _kinematics(model, home, n, effector_site, ready)
    kinematics = RobotModel(USER_ROBOT, reach, workspace, {n: lambda configuration: arm})
    return UserRobotSpec(
        model=USER_ROBOT,
        title="user's arm",
        short=USER_ROBOT,
        reach_env="ArmReach-v0",
        sensed={n: effector_site},
        markers={n: "marker_effector"},
        tool_axes={effector_site: (0.0, 0.0, 1.0)},  # the site's z
        mj_spec=spec,
        user_kinematics=kinematics,
    )


class ArmReachEnv(ReachEnv):
    """:class:`envs.reach.ReachEnv` on a user's MJCF (module docstring).

    ## Arguments
    - ``robot``: a path to an MJCF file or a ``mujoco.MjSpec`` (copied, never changed).
    - ``joints``: the names of the controlled joints (hinge or slide), in action order.
    - ``effector_site``: the name of the site the green marker is put on and the cameras sense.
    - every other argument as :class:`envs.reach.ReachEnv`'s (``sensing``, ``control``, ...).
    """

    def __init__(
        self,
        robot: str | Path | mujoco.MjSpec,
        joints: Sequence[str],
        effector_site: str,
        **kwargs: Any,
    ) -> None:
        spec = user_robot(robot, joints, effector_site)
        super().__init__(robot=spec, joints=len(joints), **kwargs)
