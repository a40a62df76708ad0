"""The PUMA's kinematics for the exact controllers (:class:`models.arms.ArmKinematics`) and its
parameter chain for the accuracy analysis.

- :func:`wrist` (3 joints): the sensed point is the wrist centre, world = ``BASE_POS`` + frame-0
  point (Brause 5.6); inverse = Brause Fig. 5c in one configuration (default right-above, in which
  the whole target box is reachable); Jacobian = rows 0-2 of the DH Jacobian at frame 4.
- :func:`tool` (6 joints): the sensed point is the tool point (frame 6) held at a fixed
  orientation; inverse = the full closed form of :mod:`models.puma560.inverse`.

A target out of reach is first moved out of the d2 cylinder about the joint-1 axis and pulled
onto the reach shell (:func:`models.arms.pull_to_shell`), as every arm's ``inverse`` does.
"""

from __future__ import annotations

import numpy as np

from models.arms import REACH_MARGIN, ArmKinematics, pull_to_shell
from models.chain import RobotChain, dh_chain
from models.joints import wrap_into_range
from models.puma560.inverse import pose_ik
from models.puma560.kinematics import (
    A2,
    A3,
    ARM_REACH,
    CONFIGURATIONS,
    D2,
    D4,
    DH,
    HOME,
    frames,
    jacobian,
    wrist_center,
    wrist_ik,
)
from models.puma560.workspace import BASE_POS, WORKSPACE
from models.rotations import homogeneous

#: Points inside the d2 cylinder about the joint-1 axis go this far (relative) outside it.
CYLINDER_MARGIN = 1e-6
#: Wrist-centre reach: R = √(|p|² - d2²) between |a2 - l4| and a2 + l4 (l4 = √(d4² + a3²)).
PUMA_R_MIN, PUMA_R_MAX = abs(A2 - float(np.hypot(D4, A3))), ARM_REACH
#: Default tool orientation for 6-joint control: z6 (approach) pointing down, frame 0.
TOOL_DOWN = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def _pull(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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
    pulled = pull_to_shell(moved, PUMA_R_MIN, PUMA_R_MAX, offset=D2)
    return pulled, np.all(pulled == p, axis=-1)


def _wrist_inverse(arm: int, elbow: int):
    def inverse(points: np.ndarray, reference: np.ndarray | None = None):
        p = np.atleast_2d(np.asarray(points, dtype=float)) - BASE_POS  # (N, 3) frame 0
        pulled, exact = _pull(p)
        theta, solvable = wrist_ik(pulled, arm, elbow)
        lower, upper = DH.lower[:3], DH.upper[:3]
        theta, in_range = wrap_into_range(theta, lower, upper, reference)
        return theta, exact & solvable & in_range

    return inverse


def _workspace_centre_pose(inverse) -> np.ndarray:
    """Joints that put the sensed point at the centre of the target box (or as close as the
    solver's branch gets: finite and in range either way)."""
    centre = 0.5 * (WORKSPACE.lower + WORKSPACE.upper)
    return inverse(centre[None, :], None)[0][0]


def _configuration(configuration: str) -> tuple[int, int]:
    if configuration not in CONFIGURATIONS:
        raise ValueError(
            f"unknown configuration {configuration!r}; valid: {', '.join(CONFIGURATIONS)}"
        )
    return CONFIGURATIONS[configuration]


def wrist(configuration: str = "right-above") -> ArmKinematics:
    """Joints 1-3 controlling the wrist centre (site ``wrist_center``)."""
    arm, elbow = _configuration(configuration)

    def forward(theta: np.ndarray) -> np.ndarray:
        return BASE_POS + wrist_center(theta)

    def jac(theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        full = np.concatenate([theta, np.zeros((*theta.shape[:-1], 3))], axis=-1)
        return jacobian(full, point=4)[..., :3, :3]

    inverse = _wrist_inverse(arm, elbow)
    return ArmKinematics(
        "puma560",
        DH.lower[:3].copy(),
        DH.upper[:3].copy(),
        HOME[:3].copy(),
        _workspace_centre_pose(inverse),
        forward,
        jac,
        inverse,
    )


def tool(
    configuration: str = "right-above", wrist: int = -1, orientation: np.ndarray = TOOL_DOWN
) -> ArmKinematics:
    """Joints 1-6 putting the tool point (site ``tcp``) at a target with a fixed orientation.

    Args:
        configuration: arm configuration of Brause Fig. 5c; wrist: +1 or -1 (sign of θ5). With the
            tool pointing down, right-above with θ5 ≤ 0 (the default) reaches 99.7 % of the
            target box (θ5 ≥ 0: 0.3 %).
        orientation: rotation of frame 6 in frame 0 (3, 3), default :data:`TOOL_DOWN`.
    """
    arm, elbow = _configuration(configuration)
    R = np.asarray(orientation, dtype=float)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
        raise ValueError(f"orientation must be a (3, 3) rotation matrix, got {R!r}")
    d6 = DH.d[5]

    def forward(theta: np.ndarray) -> np.ndarray:
        return BASE_POS + frames(theta)[..., 6, :3, 3]

    def jac(theta: np.ndarray) -> np.ndarray:
        return jacobian(theta, point=6)[..., :3, :]

    def inverse(points: np.ndarray, reference: np.ndarray | None = None):
        p = np.atleast_2d(np.asarray(points, dtype=float)) - BASE_POS  # (N, 3) frame 0
        centre, exact = _pull(p - d6 * R[:, 2])  # wrist centres, pulled into reach
        T = homogeneous(R, centre + d6 * R[:, 2])  # (N, 4, 4)
        theta, valid = pose_ik(T, arm, elbow, wrist, reference)
        return theta, valid & exact

    return ArmKinematics(
        "puma560",
        DH.lower.copy(),
        DH.upper.copy(),
        HOME.copy(),
        _workspace_centre_pose(inverse),
        forward,
        jac,
        inverse,
    )


def accuracy_chain() -> RobotChain:
    """Every DH θ, d, a, α from site ``base`` to site ``tcp``; body ``link<i+1>`` holds the fixed
    factors after joint i (the last: site ``tcp``)."""
    chain, _ = dh_chain(DH, HOME)
    segments = (*(("body", f"link{i}") for i in range(2, 7)), ("site", "tcp"))
    return RobotChain(
        "puma560", chain, tuple(range(0, 24, 4)), segments, lambda theta: dh_chain(DH, theta)[1]
    )
