"""What an exact controller needs of an arm: forward and inverse kinematics of the sensed point in
world coordinates, its position Jacobian, and the joint ranges.

- ``puma560`` (3 joints): the sensed point is the wrist centre, world = ``BASE_POS`` + frame-0
  point (Brause 5.6); inverse = Brause Fig. 5c in one configuration (default right-above, in which
  the whole PUMA target box is reachable); Jacobian = rows 0-2 of the DH Jacobian at frame 4.
- ``puma560`` (6 joints): the sensed point is the tool point (frame 6) held at a fixed orientation;
  inverse = the full closed form of :mod:`models.puma560.inverse`.
- ``riacs``: the tool point; inverse = the report's ``robot3dinv``; Jacobian from the chain of
  :data:`models.chain.RIACS_CHAIN`.

Every ``inverse`` returns finite joints inside the ranges: a target out of reach is first pulled
radially onto the reachable shell about the shoulder (the arm stretches towards it), then angles
are wrapped (±2π) or clipped into range; ``reachable`` says whether that was needed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from models import puma560, riacs
from models.chain import RIACS_CHAIN, RIACS_JOINTS, riacs_parameters
from models.joints import wrap_into_range
from models.puma560.inverse import pose_ik
from models.puma560.kinematics import A2, A3, CONFIGURATIONS, D2, D4, jacobian, wrist_center
from models.rotations import homogeneous

#: Keep pulled-in targets this far (relative) inside the reach limits, so that arccos stays real.
REACH_MARGIN = 1e-9
#: Points inside the PUMA's d2 cylinder about the joint-1 axis go this far (relative) outside it.
CYLINDER_MARGIN = 1e-6
#: PUMA wrist-centre reach: R = √(|p|² - d2²) between |a2 - l4| and a2 + l4 (l4 = √(d4² + a3²)).
PUMA_R_MIN, PUMA_R_MAX = abs(A2 - float(np.hypot(D4, A3))), puma560.ARM_REACH
#: Default tool orientation for 6-joint PUMA control: z6 (approach) pointing down, frame 0.
TOOL_DOWN = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


@dataclass(frozen=True)
class ArmKinematics:
    """Kinematics of an arm's sensed point, vectorised over a leading batch axis.

    Attributes:
        name: robot name (folder under ``models/``).
        lower, upper: joint ranges (J,), rad.
        home: the keyframe ``home`` (J,), rad.
        ready: a well-conditioned pose (J,) in the middle of the target workspace, rad, where
            iterative solvers start (the PUMA ``home`` is the stretched, singular pose of Fig. 2b).
        forward: joints (..., J) -> sensed point (..., 3), world, m.
        jacobian: joints (..., J) -> ∂point/∂joints (..., 3, J), m/rad.
        inverse: (points (N, 3) world, reference (N, J) or None) -> (joints (N, J), reachable
            (N,) bool); joints finite and in range, ``reference`` picks among ±2π turns.
    """

    name: str
    lower: np.ndarray
    upper: np.ndarray
    home: np.ndarray
    ready: np.ndarray
    forward: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    inverse: Callable[[np.ndarray, np.ndarray | None], tuple[np.ndarray, np.ndarray]]

    @property
    def n_joints(self) -> int:
        return len(self.lower)


def _pull_to_shell(p: np.ndarray, r_min: float, r_max: float, offset: float = 0.0) -> np.ndarray:
    """Scale points (N, 3) about the origin so that √(|p|² - offset²) lies in [r_min, r_max]
    (the origin itself is moved along +y)."""
    lo, hi = r_min * (1 + REACH_MARGIN), r_max * (1 - REACH_MARGIN)
    norm2 = np.sum(p**2, axis=-1)
    p = np.where((norm2 > 0)[:, None], p, [0.0, 1.0, 0.0])
    norm2 = np.sum(p**2, axis=-1)
    R = np.sqrt(np.maximum(norm2 - offset**2, 0.0))
    target = np.clip(R, lo, hi)
    scale = np.sqrt((target**2 + offset**2) / norm2)
    return np.where((R == target)[:, None], p, p * scale[:, None])


def _puma_pull(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Wrist-centre points (N, 3) in frame 0 moved into reach: out of the cylinder of radius d2
    about the joint-1 axis, then onto the reach shell. Returns (points, unchanged (N,) bool)."""
    p = np.array(p, dtype=float)
    rxy = np.hypot(p[:, 0], p[:, 1])
    inside = rxy <= D2 * (1 + REACH_MARGIN)
    direction = np.where(
        (rxy > 0)[:, None], p[:, :2] / np.maximum(rxy, 1e-300)[:, None], [0.0, 1.0]
    )
    moved = p.copy()
    moved[:, :2] = np.where(inside[:, None], direction * D2 * (1 + CYLINDER_MARGIN), p[:, :2])
    pulled = _pull_to_shell(moved, PUMA_R_MIN, PUMA_R_MAX, offset=D2)
    return pulled, np.all(pulled == p, axis=-1)


def _puma_wrist_inverse(arm: int, elbow: int):
    def inverse(points: np.ndarray, reference: np.ndarray | None = None):
        p = np.atleast_2d(np.asarray(points, dtype=float)) - puma560.BASE_POS  # (N, 3) frame 0
        pulled, exact = _puma_pull(p)
        theta, solvable = puma560.wrist_ik(pulled, arm, elbow)
        lower, upper = puma560.DH.lower[:3], puma560.DH.upper[:3]
        theta, in_range = wrap_into_range(theta, lower, upper, reference)
        return theta, exact & solvable & in_range

    return inverse


def _workspace_centre_pose(inverse) -> np.ndarray:
    """Joints that put the sensed point at the centre of the PUMA target box (or as close as the
    solver's branch gets: finite and in range either way)."""
    centre = 0.5 * (puma560.WORKSPACE.lower + puma560.WORKSPACE.upper)
    return inverse(centre[None, :], None)[0][0]


def puma560_wrist(configuration: str = "right-above") -> ArmKinematics:
    """PUMA joints 1-3 controlling the wrist centre (site ``wrist_center``)."""
    if configuration not in CONFIGURATIONS:
        raise ValueError(
            f"unknown configuration {configuration!r}; valid: {', '.join(CONFIGURATIONS)}"
        )
    arm, elbow = CONFIGURATIONS[configuration]

    def forward(theta: np.ndarray) -> np.ndarray:
        return puma560.BASE_POS + wrist_center(theta)

    def jac(theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        full = np.concatenate([theta, np.zeros((*theta.shape[:-1], 3))], axis=-1)
        return jacobian(full, point=4)[..., :3, :3]

    inverse = _puma_wrist_inverse(arm, elbow)
    return ArmKinematics(
        "puma560",
        puma560.DH.lower[:3].copy(),
        puma560.DH.upper[:3].copy(),
        puma560.HOME[:3].copy(),
        _workspace_centre_pose(inverse),
        forward,
        jac,
        inverse,
    )


def puma560_tool(
    configuration: str = "right-above", wrist: int = -1, orientation: np.ndarray = TOOL_DOWN
) -> ArmKinematics:
    """PUMA joints 1-6 putting the tool point (site ``tcp``) at a target with a fixed orientation.

    Args:
        configuration: arm configuration of Brause Fig. 5c; wrist: +1 or -1 (sign of θ5). With the
            tool pointing down, right-above with θ5 ≤ 0 (the default) reaches 99.7 % of the
            target box (θ5 ≥ 0: 0.3 %).
        orientation: rotation of frame 6 in frame 0 (3, 3), default :data:`TOOL_DOWN`.
    """
    if configuration not in CONFIGURATIONS:
        raise ValueError(
            f"unknown configuration {configuration!r}; valid: {', '.join(CONFIGURATIONS)}"
        )
    arm, elbow = CONFIGURATIONS[configuration]
    R = np.asarray(orientation, dtype=float)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
        raise ValueError(f"orientation must be a (3, 3) rotation matrix, got {R!r}")
    d6 = puma560.DH.d[5]

    def forward(theta: np.ndarray) -> np.ndarray:
        return puma560.BASE_POS + puma560.frames(theta)[..., 6, :3, 3]

    def jac(theta: np.ndarray) -> np.ndarray:
        return jacobian(theta, point=6)[..., :3, :]

    def inverse(points: np.ndarray, reference: np.ndarray | None = None):
        p = np.atleast_2d(np.asarray(points, dtype=float)) - puma560.BASE_POS  # (N, 3) frame 0
        centre, exact = _puma_pull(p - d6 * R[:, 2])  # wrist centres, pulled into reach
        T = homogeneous(R, centre + d6 * R[:, 2])  # (N, 4, 4)
        theta, valid = pose_ik(T, arm, elbow, wrist, reference)
        return theta, valid & exact

    return ArmKinematics(
        "puma560",
        puma560.DH.lower.copy(),
        puma560.DH.upper.copy(),
        puma560.HOME.copy(),
        _workspace_centre_pose(inverse),
        forward,
        jac,
        inverse,
    )


def riacs_arm() -> ArmKinematics:
    """The RIACS arm's tool point (site ``tcp``), ``robot3df`` / ``robot3dinv``."""
    l1, l2 = riacs.LINK1, riacs.LINK2

    def forward(theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        return np.stack(riacs.robot3df(l1, l2, theta[..., 0], theta[..., 1], theta[..., 2]), -1)

    def jac(theta: np.ndarray) -> np.ndarray:
        return RIACS_CHAIN.position_jacobian(riacs_parameters(theta, l1, l2), RIACS_JOINTS)

    def inverse(points: np.ndarray, reference: np.ndarray | None = None):
        p = np.atleast_2d(np.asarray(points, dtype=float))
        pulled = _pull_to_shell(p, abs(l1 - l2), l1 + l2)
        theta = np.stack(riacs.robot3dinv(l1, l2, *pulled.T), axis=-1)
        theta, in_range = wrap_into_range(theta, riacs.LOWER, riacs.UPPER, reference)
        return theta, np.all(pulled == p, axis=-1) & in_range

    home = riacs.HOME.copy()  # mid-range: well conditioned
    return ArmKinematics(
        "riacs", riacs.LOWER.copy(), riacs.UPPER.copy(), home, home.copy(), forward, jac, inverse
    )


def arm_kinematics(
    robot: str, joints: int = 3, configuration: str = "right-above"
) -> ArmKinematics:
    """The kinematics a controller of ``robot`` with ``joints`` controlled joints needs.

    Args:
        robot: ``"puma560"`` or ``"riacs"``.
        joints: 3 (PUMA wrist centre, RIACS tool point) or 6 (PUMA tool point, tool pointing
            down, :data:`TOOL_DOWN`).
        configuration: PUMA arm configuration of Brause Fig. 5c (ignored for RIACS).
    """
    if robot == "riacs" and joints == 3:
        return riacs_arm()
    if robot == "puma560" and joints == 3:
        return puma560_wrist(configuration)
    if robot == "puma560" and joints == 6:
        return puma560_tool(configuration)
    raise ValueError(
        f"no kinematics for robot {robot!r} with {joints!r} joints; valid: riacs with 3, "
        "puma560 with 3 or 6"
    )
