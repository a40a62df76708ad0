"""An arm given by its Denavit-Hartenberg table: the table file, its forward kinematics and
position Jacobian, and its :class:`~models.robot_model.RobotModel`.

Both conventions are read, each as its source prints it (one row per joint i):

- ``standard`` (Denavit-Hartenberg; Universal Robots' tables):
  T_i = T_(i-1) · Rz(θ_i + offset_i) · Tz(d_i) · Tx(a_i) · Rx(α_i), joint i turns about z_(i-1);
- ``modified`` (Craig; Franka's table): row i holds a_(i-1) and α_(i-1),
  T_i = T_(i-1) · Rx(α_(i-1)) · Tx(a_(i-1)) · Rz(θ_i + offset_i) · Tz(d_i), joint i turns about z_i.

Either chain is written here as world = B · F_0 · Rz(q_1) · F_1 · ... · Rz(q_n) · F_n with fixed
transforms F (:func:`fixed_transforms`): body ``link<i>`` of the generated MJCF sits at F_(i-1) in
its parent and turns about its own z, the site ``tcp`` at F_n in ``link<n>``. The table file
format is in ``docs/your-robot.md``; :mod:`models.dh_mjcf` writes the robot folder.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import tomllib

from models.arms import ArmKinematics
from models.numeric_ik import solve_positions
from models.robot_model import RobotModel
from models.workspace import BoxWorkspace

CONVENTIONS = ("standard", "modified")
ANGLE_UNITS = {"deg": math.pi / 180.0, "rad": 1.0}
#: Keys of one row of the table file; angles in the file's ``angle_unit``, lengths in metres.
ROW_KEYS = ("a", "d", "alpha", "offset", "lower", "upper", "home", "radius")
ROW_DEFAULTS = {"offset": 0.0}
TOOL_KEYS = ("a", "d", "alpha", "theta")
DEFAULT_MARKER_RADIUS = 0.03  # m
#: Random joint vectors a folder's camera placement and reach estimate sample.
WORKSPACE_SAMPLES = 4000


class DHTableError(ValueError):
    """A DH table file that cannot describe an arm; the message names the file and the entry."""


@dataclass(frozen=True)
class DHArm:
    """One arm: its DH table, joint ranges, home pose, link radii and where it stands.

    Attributes:
        name: the robot's folder name (``ur5e``); title: its name in figures.
        convention: ``"standard"`` or ``"modified"`` (module docstring).
        source: where the table comes from (written into the folder's README).
        a, d, alpha, offset: the table's columns (n,), m and rad (``offset``: θ's constant).
        lower, upper, home: joint ranges and the keyframe ``home`` (n,), rad.
        radius: each link's capsule radius (n,), m.
        tool: the fixed row after the last joint (a, d, alpha, theta) in the table's convention
            (Franka's flange), zeros for none.
        base_height: height of frame 0 above the floor (m).
        marker_radius: the green marker sphere at the tcp (m).
        controlled: the numbers of controlled joints the robot offers (the others at home).
        workspace_lower, workspace_upper: the box reach targets are drawn from (world, m).
        grasp_box: the pose task's half-widths (n,), rad: its objects are the hand's poses at
            joints within them of ``grasp_ready`` (``models/dh_grasp.py``); None: no pose task.
        grasp_ready: the pose task's taught pose (n,), rad (keyframe ``grasp_ready``), None for
            ``ready``'s.
    """

    name: str
    title: str
    convention: str
    source: str
    a: np.ndarray
    d: np.ndarray
    alpha: np.ndarray
    offset: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    home: np.ndarray
    radius: np.ndarray
    tool: np.ndarray
    base_height: float
    marker_radius: float
    controlled: tuple[int, ...]
    workspace_lower: np.ndarray
    workspace_upper: np.ndarray
    grasp_box: np.ndarray | None = None
    grasp_ready: np.ndarray | None = None

    @property
    def n(self) -> int:
        return len(self.a)


# -- the table file -----------------------------------------------------------------------------


def read_table(path: Path | str) -> DHArm:
    """The arm of a TOML (``.toml``) or JSON (``.json``) table file; DHTableError naming the file
    and what is wrong or missing."""
    path = Path(path)
    if not path.is_file():
        raise DHTableError(f"no DH table file {path}; give a .toml or .json file")
    text = path.read_text()
    try:
        if path.suffix == ".toml":
            raw = tomllib.loads(text)
        elif path.suffix == ".json":
            raw = json.loads(text)
        else:
            raise DHTableError(f"{path}: a DH table is a .toml or .json file, not {path.suffix!r}")
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as error:
        raise DHTableError(f"{path}: not valid {path.suffix[1:].upper()}: {error}") from None
    return parse_table(raw, str(path))


def _number(where: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise DHTableError(f"{where}: {key} must be a finite number, got {value!r}")
    return float(value)


def _text(where: str, raw: Mapping[str, Any], key: str) -> str:
    value = raw.get(key)
    if not isinstance(value, str) or not value.strip():
        raise DHTableError(f'{where}: give {key} = "..." (a non-empty string)')
    return value


def _vector3(where: str, key: str, value: Any) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 3:
        raise DHTableError(f"{where}: {key} must be a list of 3 numbers (m), got {value!r}")
    return np.array([_number(where, key, v) for v in value])


def parse_table(raw: Mapping[str, Any], where: str = "DH table") -> DHArm:
    """The arm of a table file's contents (the mapping TOML or JSON gives)."""
    name = _text(where, raw, "name")
    if not name.isidentifier() or name != name.lower():
        raise DHTableError(f"{where}: name {name!r} must be a lower-case Python identifier")
    convention = raw.get("convention")
    if convention not in CONVENTIONS:
        raise DHTableError(f"{where}: convention must be one of {CONVENTIONS}, got {convention!r}")
    unit = raw.get("angle_unit")
    if unit not in ANGLE_UNITS:
        raise DHTableError(f"{where}: angle_unit must be 'deg' or 'rad', got {unit!r}")
    scale = ANGLE_UNITS[unit]
    rows = raw.get("joint")
    if not isinstance(rows, list) or not rows or not all(isinstance(r, dict) for r in rows):
        raise DHTableError(f"{where}: give the table as [[joint]] rows (one per joint)")
    columns: dict[str, list[float]] = {key: [] for key in ROW_KEYS}
    for i, row in enumerate(rows, start=1):
        unknown = sorted(set(row) - set(ROW_KEYS))
        if unknown:
            raise DHTableError(f"{where}: joint {i} has unknown keys {unknown}; valid: {ROW_KEYS}")
        for key in ROW_KEYS:
            if key not in row and key not in ROW_DEFAULTS:
                raise DHTableError(f"{where}: joint {i} has no {key}")
            value = _number(f"{where}: joint {i}", key, row.get(key, ROW_DEFAULTS.get(key)))
            columns[key].append(value * scale if key in ("alpha", "offset", "lower", "upper",
                                                         "home") else value)  # fmt: skip
    a, d, alpha, offset, lower, upper, home, radius = (np.array(columns[k]) for k in ROW_KEYS)
    for i in range(len(a)):
        if not lower[i] < upper[i]:
            raise DHTableError(f"{where}: joint {i + 1} has lower ≥ upper; give lower < upper")
        if not lower[i] <= home[i] <= upper[i]:
            raise DHTableError(f"{where}: joint {i + 1}'s home is outside [lower, upper]")
        if not radius[i] > 0:
            raise DHTableError(f"{where}: joint {i + 1}'s link radius must be > 0 (m)")
    tool_raw = raw.get("tool", {})
    if not isinstance(tool_raw, dict) or set(tool_raw) - set(TOOL_KEYS):
        raise DHTableError(f"{where}: [tool] takes only the keys {TOOL_KEYS}")
    tool = np.array([_number(f"{where}: tool", k, tool_raw.get(k, 0.0)) for k in TOOL_KEYS])
    tool[2:] *= scale
    controlled = raw.get("controlled", [len(a)])
    if (
        not isinstance(controlled, list)
        or not controlled
        or not all(isinstance(c, int) and not isinstance(c, bool) for c in controlled)
        or not all(1 <= c <= len(a) for c in controlled)
    ):
        raise DHTableError(
            f"{where}: controlled must list joint counts between 1 and {len(a)}, got {controlled!r}"
        )
    workspace = raw.get("workspace")
    if not isinstance(workspace, dict) or set(workspace) != {"lower", "upper"}:
        raise DHTableError(
            f"{where}: give [workspace] lower = [x, y, z] and upper = [x, y, z] (world, m): the "
            "box reach targets are drawn from"
        )
    box_lower = _vector3(f"{where}: workspace", "lower", workspace["lower"])
    box_upper = _vector3(f"{where}: workspace", "upper", workspace["upper"])
    if not np.all(box_lower < box_upper):
        raise DHTableError(f"{where}: workspace lower must be below upper in x, y and z")
    grasp_box, grasp_ready = _grasp(where, raw.get("grasp"), len(a), scale, lower, upper)
    marker = _number(where, "marker_radius", raw.get("marker_radius", DEFAULT_MARKER_RADIUS))
    if marker <= 0:
        raise DHTableError(f"{where}: marker_radius must be > 0 (m)")
    return DHArm(
        name=name,
        title=_text(where, raw, "title"),
        convention=convention,
        source=_text(where, raw, "source"),
        a=a,
        d=d,
        alpha=alpha,
        offset=offset,
        lower=lower,
        upper=upper,
        home=home,
        radius=radius,
        tool=tool,
        base_height=_number(where, "base_height", raw.get("base_height", 0.0)),
        marker_radius=marker,
        controlled=tuple(sorted(set(controlled))),
        workspace_lower=box_lower,
        workspace_upper=box_upper,
        grasp_box=grasp_box,
        grasp_ready=grasp_ready,
    )


def _grasp(where: str, raw: Any, n: int, scale: float, lower: np.ndarray, upper: np.ndarray
           ) -> tuple[np.ndarray | None, np.ndarray | None]:  # fmt: skip
    """The ``[grasp]`` section's ``joint_box`` (n,) half-widths and optional ``ready`` (n,)
    pose, rad (None, None without a section)."""
    if raw is None:
        return None, None
    usage = (
        f"give [grasp] joint_box = [{n} half-widths > 0] and optionally ready = [{n} angles in "
        "the joint ranges], in the table's angle_unit"
    )
    if not isinstance(raw, dict) or "joint_box" not in raw or set(raw) - {"joint_box", "ready"}:
        raise DHTableError(f"{where}: [grasp] takes joint_box and ready; {usage}")
    values = {}
    for key in raw:
        column = raw[key]
        if not isinstance(column, list) or len(column) != n:
            raise DHTableError(f"{where}: [grasp] {key} is {column!r}; {usage}")
        values[key] = np.array([_number(f"{where}: grasp", key, v) for v in column]) * scale
    if not np.all(values["joint_box"] > 0):
        raise DHTableError(f"{where}: [grasp] joint_box has a half-width <= 0; {usage}")
    ready = values.get("ready")
    if ready is not None and not np.all((lower <= ready) & (ready <= upper)):
        raise DHTableError(f"{where}: [grasp] ready is outside the joint ranges; {usage}")
    return values["joint_box"], ready


# -- kinematics ---------------------------------------------------------------------------------


#: One elementary factor of a fixed transform: ("rz" | "rx", angle rad) or ("tz" | "tx", m).
Factor = tuple[str, float]


def elementary(kind: str, value: float) -> np.ndarray:
    """The 4×4 transform of one factor: a rotation about or a shift along x or z."""
    T = np.eye(4)
    if kind in ("rz", "rx"):
        c, s = math.cos(value), math.sin(value)
        i, j = (0, 1) if kind == "rz" else (1, 2)
        T[i, i], T[i, j], T[j, i], T[j, j] = c, -s, s, c
    else:
        T[0 if kind == "tx" else 2, 3] = value
    return T


def fixed_factors(arm: DHArm) -> list[list[Factor]]:
    """The factors of F_0 .. F_n (module docstring), in order."""
    factors: list[list[Factor]] = [[] for _ in range(arm.n + 1)]
    ta, td, talpha, ttheta = (float(v) for v in arm.tool)
    for i in range(arm.n):
        a, d, alpha, offset = (float(arm.a[i]), float(arm.d[i]), float(arm.alpha[i]),
                               float(arm.offset[i]))  # fmt: skip
        if arm.convention == "standard":  # Rz(q + offset) Tz(d) Tx(a) Rx(α): after Rz(q_i)
            factors[i + 1] += [("rz", offset), ("tz", d), ("tx", a), ("rx", alpha)]
        else:  # Rx(α) Tx(a) Rz(q + offset) Tz(d) = Rx(α) Tx(a) Tz(d) Rz(offset) · Rz(q)
            factors[i] += [("rx", alpha), ("tx", a), ("tz", d), ("rz", offset)]
    if arm.convention == "standard":
        factors[arm.n] += [("rz", ttheta), ("tz", td), ("tx", ta), ("rx", talpha)]
    else:
        factors[arm.n] += [("rx", talpha), ("tx", ta), ("rz", ttheta), ("tz", td)]
    return factors


def fixed_transforms(arm: DHArm) -> np.ndarray:
    """F_0 .. F_n (n + 1, 4, 4): world = B · F_0 · Rz(q_1) · F_1 · ... · Rz(q_n) · F_n."""
    F = np.tile(np.eye(4), (arm.n + 1, 1, 1))
    for i, factors in enumerate(fixed_factors(arm)):
        for kind, value in factors:
            F[i] = F[i] @ elementary(kind, value)
    return F


def base_transform(arm: DHArm) -> np.ndarray:
    """B: frame 0 (site ``base``) in the world, ``base_height`` above the floor."""
    return elementary("tz", arm.base_height)


def joint_frames(arm: DHArm, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The frames in which each joint turns, and the tcp.

    Args:
        theta: all n joint angles (..., n), rad.
    Returns:
        axes (..., n, 4, 4): world frame whose z is joint i's axis through its origin;
        tcp (..., 4, 4): the tcp frame in the world.
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape[-1] != arm.n:
        raise ValueError(f"{arm.name} has {arm.n} joints; got angles of shape {theta.shape}")
    F = fixed_transforms(arm)
    c, s = np.cos(theta), np.sin(theta)
    T = np.broadcast_to(base_transform(arm) @ F[0], (*theta.shape[:-1], 4, 4))
    axes = []
    for i in range(arm.n):
        axes.append(T)
        Rz = np.zeros((*theta.shape[:-1], 4, 4))  # joint i's turn about z
        Rz[..., 0, 0] = Rz[..., 1, 1] = c[..., i]
        Rz[..., 0, 1], Rz[..., 1, 0] = -s[..., i], s[..., i]
        Rz[..., 2, 2] = Rz[..., 3, 3] = 1.0
        T = T @ Rz @ F[i + 1]
    return np.stack(axes, axis=-3), T


def tcp_position(arm: DHArm, theta: np.ndarray) -> np.ndarray:
    """World position of the tcp (..., 3), m, for all n joint angles (..., n)."""
    return joint_frames(arm, theta)[1][..., :3, 3]


def tcp_jacobian(arm: DHArm, theta: np.ndarray) -> np.ndarray:
    """∂tcp/∂θ (..., 3, n), m/rad: column i is z_i × (tcp - p_i)."""
    axes, tcp = joint_frames(arm, theta)
    z, p = axes[..., :3, 2], axes[..., :3, 3]  # (..., n, 3)
    return np.swapaxes(np.cross(z, tcp[..., None, :3, 3] - p), -1, -2)


def sample_reachable(arm: DHArm, rng: np.random.Generator, n: int) -> np.ndarray:
    """tcp positions (n, 3) of joint vectors drawn uniformly from the joint ranges."""
    return tcp_position(arm, rng.uniform(arm.lower, arm.upper, size=(n, arm.n)))


def reach(arm: DHArm) -> float:
    """The arm's reach (m): the tcp's largest distance from the site ``base`` over
    :data:`WORKSPACE_SAMPLES` joint vectors drawn from the joint ranges (seed 0)."""
    points = sample_reachable(arm, np.random.default_rng(0), WORKSPACE_SAMPLES)
    return float(np.max(np.linalg.norm(points - base_transform(arm)[:3, 3], axis=-1)))


# -- the exact controllers' kinematics -----------------------------------------------------------


def arm_kinematics(arm: DHArm, joints: int) -> ArmKinematics:
    """The tcp's kinematics with joints 1..``joints`` controlled and the others at home; the
    inverse is numerical (:func:`models.numeric_ik.solve_positions`) from the reference, the
    ``ready`` pose and seeded restarts."""
    rest = arm.home[joints:]
    lower, upper = arm.lower[:joints].copy(), arm.upper[:joints].copy()

    def full(theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        return np.concatenate([theta, np.broadcast_to(rest, (*theta.shape[:-1], len(rest)))], -1)

    def forward(theta: np.ndarray) -> np.ndarray:
        return tcp_position(arm, full(theta))

    def jacobian(theta: np.ndarray) -> np.ndarray:
        return tcp_jacobian(arm, full(theta))[..., :joints]

    centre = 0.5 * (arm.workspace_lower + arm.workspace_upper)
    ready = solve_positions(forward, jacobian, centre[None], arm.home[None, :joints], lower,
                            upper)[0][0]  # fmt: skip

    def inverse(points: np.ndarray, reference: np.ndarray | None = None):
        p = np.atleast_2d(np.asarray(points, dtype=float))
        start = np.broadcast_to(ready if reference is None else reference, (len(p), joints))
        return solve_positions(forward, jacobian, p, start, lower, upper)

    return ArmKinematics(arm.name, lower, upper, arm.home[:joints].copy(), ready, forward,
                         jacobian, inverse)  # fmt: skip


def configured_kinematics(arm: DHArm, joints: int, configuration: Any) -> ArmKinematics:
    """:func:`arm_kinematics` as a :class:`RobotModel`'s ``arms`` entry (a DH arm has one
    configuration)."""
    return arm_kinematics(arm, joints)


def dh_robot_model(arm: DHArm) -> RobotModel:
    """The arm's :class:`RobotModel`: reach, the workspace box, the tcp kinematics for each
    number of controlled joints it offers, and the pose task if the table has ``[grasp]``."""
    from models.dh_grasp import grasp_task  # it builds on this module's kinematics

    # partials of module functions, not lambdas: envs pickle (AsyncVectorEnv)
    arms = {j: partial(configured_kinematics, arm, j) for j in arm.controlled}
    workspace = BoxWorkspace(arm.workspace_lower.copy(), arm.workspace_upper.copy())
    grasp = None if arm.grasp_box is None else grasp_task(arm)
    return RobotModel(name=arm.name, reach=reach(arm), workspace=workspace, arms=arms,
                      grasp=grasp)  # fmt: skip
