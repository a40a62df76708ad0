"""TCP paths for the PUMA 560: circles and straight lines with an orientation profile.

A path is sampled at ``n_steps + 1`` instants ``t_k = k·dt``: world positions (m), tool rotation
matrices (columns = tool axes x6, y6, z6 in the world frame), and the desired linear (m/s) and
angular (rad/s, world frame) velocity at each instant, from the analytic derivatives.

Orientation profiles rotate the start orientation R0 about a fixed tool-frame axis ``a``:
R(t) = R0·exp(φ(t)·[a]), so the world angular velocity is ω = φ'(t)·R0·a. A circle uses
φ = A·sin(ψ) (ψ the angle travelled, so the orientation returns to R0 after one revolution); a
line turns uniformly, φ = s·A with s ∈ [0, 1].

:func:`sample_path` draws paths inside the PUMA workspace: the start pose comes from a random joint
configuration (wrist centre in :data:`models.puma560.WORKSPACE`, right-above arm, wrist bent away
from its singularity), and a path is kept only if every sample has its TCP in the workspace box and
a closed-form inverse kinematics solution (:func:`pose_ik`) with all joints in range, the wrist at
least ``WRIST_MARGIN`` from θ5 = 0, joints moving at most ``MAX_SAMPLE_JOINT_STEP`` per
sample, and a Jacobian no closer to singular than
``MIN_SINGULAR_VALUE``. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.puma560 import BASE_POS, DH, WORKSPACE, frames, inverse, wrist_ik
from models.puma560.kinematics import jacobian
from models.rotations import homogeneous, rotvec_to_matrix

DEG = np.pi / 180.0
PATH_KINDS = ("circle", "line")
#: Arm configuration of every path: right arm, elbow above (Brause Fig. 5c), as the workspace box.
ARM, ELBOW = 1, 1
#: Start configurations: joints 4-6 drawn from these ranges (rad); θ5 > 0 keeps one wrist branch.
THETA4_RANGE = (-45.0 * DEG, 45.0 * DEG)
THETA5_RANGE = (35.0 * DEG, 75.0 * DEG)
THETA6_RANGE = (-90.0 * DEG, 90.0 * DEG)
#: Nearest a path may bring θ5 to the wrist singularity θ5 = 0 (rad).
WRIST_MARGIN = 20.0 * DEG
#: Largest joint change between consecutive samples (rad): half of PumaTrack's action bound.
MAX_SAMPLE_JOINT_STEP = 0.05
#: Smallest singular value of the tcp Jacobian along a path (mixed m/rad and rad/rad units).
MIN_SINGULAR_VALUE = 0.05
#: Random path geometry: circle radius (m), line length (m), orientation amplitude (rad).
RADIUS_RANGE = (0.05, 0.12)
LENGTH_RANGE = (0.10, 0.30)
AMPLITUDE_RANGE = (5.0 * DEG, 20.0 * DEG)
#: Default sampling: steps per path and control period (s).
N_STEPS = 100
DT = 0.04
#: Draws of :func:`sample_path` before it gives up.
MAX_TRIES = 1000


def tcp_pose(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World TCP position (..., 3) (m) and rotation (..., 3, 3) for joints (..., 6) (rad)."""
    T = frames(theta)[..., 6, :, :]
    return T[..., :3, 3] + BASE_POS, T[..., :3, :3]


def pose_ik(
    position: np.ndarray, rotation: np.ndarray, arm: int = ARM, elbow: int = ELBOW, wrist: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Joints for world TCP poses: :func:`models.puma560.inverse.pose_ik` in world coordinates.

    Args:
        position: world TCP positions (..., 3), m. rotation: (..., 3, 3).
        arm, elbow: Brause's ARM and ELBOW indicators (±1). wrist: +1 for θ5 ≥ 0, -1 for θ5 ≤ 0.
    Returns:
        theta (..., 6) rad, in the joint ranges; valid (...,) bool (reachable, in range).
    """
    T06 = homogeneous(rotation, np.asarray(position, dtype=float) - BASE_POS)
    return inverse.pose_ik(T06, arm, elbow, wrist)


@dataclass(frozen=True)
class Path:
    """A sampled TCP path: ``n_steps + 1`` samples, ``dt`` seconds apart (see module doc)."""

    kind: str
    dt: float  # s
    positions: np.ndarray  # (n+1, 3) world, m
    rotations: np.ndarray  # (n+1, 3, 3) tool axes as columns, world frame
    linear_velocity: np.ndarray  # (n+1, 3) m/s
    angular_velocity: np.ndarray  # (n+1, 3) rad/s, world frame
    joints: np.ndarray  # (n+1, 6) rad: the inverse kinematics solution, unwrapped along the path

    @property
    def n_steps(self) -> int:
        return len(self.positions) - 1

    def twist(self, k: int) -> np.ndarray:
        """Desired velocity (6,) at sample k: linear (m/s) then angular (rad/s)."""
        return np.concatenate([self.linear_velocity[k], self.angular_velocity[k]])


def _orthonormal(normal: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A random unit vector perpendicular to ``normal``."""
    n = normal / np.linalg.norm(normal)
    v = rng.standard_normal(3)
    v -= (v @ n) * n
    return v / np.linalg.norm(v)


def _finish(kind: str, dt: float, positions, linear, R0, axis, phi, phi_dot) -> Path:
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    rotations = R0 @ rotvec_to_matrix(phi[:, None] * axis)  # (n+1, 3, 3)
    angular = phi_dot[:, None] * (R0 @ axis)  # (n+1, 3)
    joints, _ = pose_ik(positions, rotations, wrist=1)
    return Path(kind, dt, positions, rotations, linear, angular, np.unwrap(joints, axis=0))


def circle_path(
    centre: np.ndarray,
    radius: float,
    normal: np.ndarray,
    start_dir: np.ndarray,
    R0: np.ndarray,
    axis: np.ndarray,
    amplitude: float,
    n_steps: int = N_STEPS,
    dt: float = DT,
) -> Path:
    """One revolution of a circle, ``n_steps`` steps, starting at centre + radius·start_dir.

    Args:
        centre: world centre (3,), m; radius: m; normal: (3,) plane normal (direction of travel
            by the right-hand rule); start_dir: (3,) in the plane (made perpendicular to normal).
        R0: tool rotation at the start; axis: tool-frame axis (3,) of the orientation profile;
            amplitude: rad, the profile is φ = amplitude·sin(ψ).
    """
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    u = np.asarray(start_dir, dtype=float) - (np.asarray(start_dir) @ n) * n
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    rate = 2.0 * np.pi / (n_steps * dt)  # rad/s
    psi = rate * dt * np.arange(n_steps + 1)
    positions = centre + radius * (np.cos(psi)[:, None] * u + np.sin(psi)[:, None] * v)
    linear = radius * rate * (-np.sin(psi)[:, None] * u + np.cos(psi)[:, None] * v)
    phi, phi_dot = amplitude * np.sin(psi), amplitude * rate * np.cos(psi)
    return _finish("circle", dt, positions, linear, R0, axis, phi, phi_dot)


def line_path(
    start: np.ndarray,
    end: np.ndarray,
    R0: np.ndarray,
    axis: np.ndarray,
    angle: float,
    n_steps: int = N_STEPS,
    dt: float = DT,
) -> Path:
    """A straight line at constant speed, turning uniformly by ``angle`` (rad) about ``axis``."""
    s = np.arange(n_steps + 1) / n_steps
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    positions = start + s[:, None] * (end - start)
    duration = n_steps * dt
    linear = np.broadcast_to((end - start) / duration, positions.shape).copy()
    phi, phi_dot = angle * s, np.full_like(s, angle / duration)
    return _finish("line", dt, positions, linear, R0, axis, phi, phi_dot)


def path_is_valid(path: Path) -> bool:
    """Every sample inside the workspace box, in joint range, away from singularities, and
    joint steps no larger than MAX_SAMPLE_JOINT_STEP (module doc)."""
    _, reachable = pose_ik(path.positions, path.rotations, wrist=1)
    q = path.joints
    in_range = np.all((q >= DH.lower) & (q <= DH.upper))
    if not (np.all(reachable) and in_range and np.all(WORKSPACE.contains(path.positions))):
        return False
    if np.any(q[:, 4] < WRIST_MARGIN) or np.abs(np.diff(q, axis=0)).max() > MAX_SAMPLE_JOINT_STEP:
        return False
    singular_values = np.linalg.svd(jacobian(q), compute_uv=False)  # (n+1, 6)
    return bool(singular_values[:, -1].min() >= MIN_SINGULAR_VALUE)


def _random_start(rng: np.random.Generator) -> np.ndarray:
    """A joint configuration: wrist centre uniform in the workspace box, random wrist angles."""
    while True:
        centre = WORKSPACE.sample(rng, 1)[0] - BASE_POS
        arm, ok = wrist_ik(centre, ARM, ELBOW)
        wrist = rng.uniform(*np.array([THETA4_RANGE, THETA5_RANGE, THETA6_RANGE]).T)
        theta = np.concatenate([arm, wrist])
        if ok and np.all((theta >= DH.lower) & (theta <= DH.upper)):
            return theta


def _random_unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


def sample_path(
    rng: np.random.Generator,
    kind: str = "circle",
    n_steps: int = N_STEPS,
    dt: float = DT,
    radius: float | None = None,
) -> Path:
    """A random valid path of ``kind`` ("circle" or "line"); ``radius`` fixes a circle's radius.

    Raises:
        ValueError: unknown kind, or no valid path found in MAX_TRIES draws.
    """
    if kind not in PATH_KINDS:
        raise ValueError(f"unknown path kind {kind!r}; valid kinds: {', '.join(PATH_KINDS)}")
    for _ in range(MAX_TRIES):
        theta = _random_start(rng)
        p0, R0 = tcp_pose(theta)
        axis, amplitude = _random_unit(rng), rng.uniform(*AMPLITUDE_RANGE)
        if kind == "circle":
            r = rng.uniform(*RADIUS_RANGE) if radius is None else radius
            normal = _random_unit(rng)
            u = _orthonormal(normal, rng)
            path = circle_path(p0 - r * u, r, normal, u, R0, axis, amplitude, n_steps, dt)
        else:
            end = p0 + rng.uniform(*LENGTH_RANGE) * _random_unit(rng)
            path = line_path(p0, end, R0, axis, amplitude, n_steps, dt)
        if path_is_valid(path):
            return path
    raise ValueError(f"no valid {kind} path in {MAX_TRIES} draws; widen the sampling ranges")
