"""Kinematic accuracy of an arm: which chain parameter moves the tool point most, and a check
of Němeček's linear error model against MuJoCo models built with perturbed parameters.

Each robot is a :class:`~models.chain.Chain` whose factors follow its MJCF: between joint i and
joint i+1 the fixed factors are exactly the local transform (``pos``, ``quat``) of the body that
holds joint i+1 (for the last joint: of site ``tcp``). A deviation Δk is written into a copy of the
MJCF there; a joint-angle deviation Δθ_i (an encoder offset) becomes a rotation about joint i's
axis prepended to that local transform, so ``qpos`` stays the nominal θ.

Deviation sizes (:func:`deviation`): ``level`` × |k_j| (0.1 % and 1 % in the script); a parameter
that is zero (PUMA a1, d3, α6, θ4 at home, ...) gets ``level`` × 0.1 m or ``level`` × 100°, i.e.
0.1 mm / 0.1° at the 0.1 % level and 1 mm / 1° at 1 %.

mujoco is imported only by the functions that build models.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models import available_models, robot_path
from models.chain import RobotChain, elementary, small_angles
from models.robot_model import robot_model

ZERO_LENGTH_SCALE = 0.1  #: m: deviation of a zero length = level × this
ZERO_ANGLE_SCALE = np.deg2rad(100.0)  #: rad: deviation of a zero angle = level × this


def robot_chain(robot: str) -> RobotChain:
    """The chain of ``robot`` (:attr:`~models.robot_model.RobotModel.chain`: the PUMA's every DH
    θ, d, a, α; the RIACS arm's θ1-θ3, link1, link2); ValueError naming the robots that have
    one."""
    model = robot_model(robot)
    if model.chain is None:
        raise ValueError(f"no chain for robot {robot!r}; valid: {', '.join(chain_robots())}")
    return model.chain()


def chain_robots() -> tuple[str, ...]:
    """The robots whose model has a chain for this analysis."""
    return tuple(name for name in available_models() if robot_model(name).chain is not None)


def sensitivity(rc: RobotChain, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tool-point displacement and rotation per unit deviation of each parameter, in frame 0.

    Returns:
        dp (N, 3): ∂p/∂k_j, m per m or m per rad; dphi (N, 3): small rotation per unit, rad per m
        or rad per rad.
    """
    k = rc.parameters(theta)
    n = len(rc.chain)
    H0, _ = rc.chain.error_matrices(np.broadcast_to(k, (n, n)), np.eye(n))
    return H0[:, :3, 3], small_angles(H0)


def deviation(rc: RobotChain, k: np.ndarray, level: float) -> np.ndarray:
    """Deviation magnitude of every parameter at ``level`` (0.001 = 0.1 %), see module docstring."""
    zero = np.where(rc.is_angle(), ZERO_ANGLE_SCALE, ZERO_LENGTH_SCALE)
    magnitude = np.abs(k)
    return level * np.where(magnitude > 1e-12, magnitude, zero)


def perturbed_model(rc: RobotChain, k: np.ndarray, dk: np.ndarray):
    """Compile the robot's MJCF with every segment rebuilt from the chain with k + dk.

    Args:
        k: nominal parameters (N,); dk: deviations (N,), rad or m.
    Returns:
        mujoco.MjModel of the robot alone.
    """
    import mujoco

    spec = mujoco.MjSpec.from_file(str(robot_path(rc.robot)))
    k, dk = np.asarray(k, dtype=float), np.asarray(dk, dtype=float)
    bounds = [*rc.joints, len(rc.chain)]
    for i, (kind, name) in enumerate(rc.segments):
        joint = rc.chain.elements[rc.joints[i]]
        T = elementary(joint.kind, joint.sign * dk[rc.joints[i]])  # encoder offset
        for j in range(bounds[i] + 1, bounds[i + 1]):
            e = rc.chain.elements[j]
            T = T @ elementary(e.kind, e.sign * (k[j] + dk[j]))
        element = spec.body(name) if kind == "body" else spec.site(name)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, T[:3, :3].flatten())
        element.pos, element.quat = T[:3, 3], quat
    return spec.compile()


def tool_pose(model, theta: np.ndarray) -> np.ndarray:
    """T of site ``tcp`` in site ``base`` (4, 4) after setting qpos = theta (J,) and kinematics."""
    import mujoco

    data = mujoco.MjData(model)
    data.qpos[: len(theta)] = theta
    mujoco.mj_kinematics(model, data)
    poses = []
    for site in ("base", "tcp"):
        T = np.eye(4)
        T[:3, :3] = data.site(site).xmat.reshape(3, 3)
        T[:3, 3] = data.site(site).xpos
        poses.append(T)
    return np.linalg.solve(poses[0], poses[1])


@dataclass(frozen=True)
class LinearCheck:
    """Predicted (linear model) and actual (MuJoCo) tool errors in frame 0, m and rad.

    single_*: (N, 3), one parameter deviated at a time; all_*: (3,), all at once with the signs.
    """

    dk: np.ndarray  # (N,) signed deviations
    single_predicted: np.ndarray
    single_actual: np.ndarray
    all_predicted: np.ndarray
    all_actual: np.ndarray
    all_angle_predicted: np.ndarray
    all_angle_actual: np.ndarray


def check_linear_model(
    rc: RobotChain, theta: np.ndarray, level: float, rng: np.random.Generator
) -> LinearCheck:
    """Deviate each parameter by ``level`` (and all at once, random signs from ``rng``), build the
    MuJoCo models, and compare the tool error with H_{0,0n}'s prediction."""
    theta = np.asarray(theta, dtype=float)
    k = rc.parameters(theta)
    n = len(rc.chain)
    dk = deviation(rc, k, level) * rng.choice([-1.0, 1.0], size=n)
    nominal = tool_pose(perturbed_model(rc, k, np.zeros(n)), theta)
    H_single, _ = rc.chain.error_matrices(np.broadcast_to(k, (n, n)), np.diag(dk))
    actual_single = np.stack(
        [tool_pose(perturbed_model(rc, k, dk * np.eye(n)[j]), theta)[:3, 3] for j in range(n)]
    )
    H_all, _ = rc.chain.error_matrices(k, dk)
    T_all = tool_pose(perturbed_model(rc, k, dk), theta)
    rotation_error = T_all[:3, :3] @ nominal[:3, :3].T  # ≈ E + ΔΘ_{0,0n}
    return LinearCheck(
        dk=dk,
        single_predicted=H_single[:, :3, 3],
        single_actual=actual_single - nominal[:3, 3],
        all_predicted=H_all[:3, 3],
        all_actual=T_all[:3, 3] - nominal[:3, 3],
        all_angle_predicted=small_angles(H_all),
        all_angle_actual=small_angles(rotation_error),
    )
