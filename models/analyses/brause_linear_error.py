"""Brause (1989) §5-6: the error of the linear approximation along a path, and storage (table 6a).

Linear approximation (3.7, 5.3-5.4): a converged map holds, at a cell centre w_c, the exact joints
Θ_c = t(w_c) (Fig. 5c, right-above) and A_c, the central difference
A_ij = [t_i(w_c + dx e_j/2) - t_i(w_c - dx e_j/2)] / dx (5.4; dx small, :data:`DX`, so A_c is the
tangent the text assumes). A point x of the cell gets Θ(x) = Θ_c + A_c (x - w_c).

Errors at the cell border (Figs. 5g, 5h): each path point is taken as a cell centre w_c of a cubic
cell of edge Δx = X/n, X = :data:`BRAUSE_EDGE` (his 717 mm cube), and Θ(x) is compared with t(x) at
the 8 corners and 6 face centres of the cell (|x - w_c| up to Δx/2 per component, as in B.4):
joint error = max over those points and the three joints of |t_i(x) - Θ_i(x)| (rad); Cartesian
error = max |x - p(Θ(x))| with p the wrist-centre kinematics (5.6) (m). A path point whose cell
border leaves the reachable region (joint ranges of the right-above solution included) has no
error (NaN).
"""

from __future__ import annotations

import numpy as np

from models.puma560 import WORKSPACE_BASE_LOWER, WORKSPACE_BASE_UPPER
from models.puma560.kinematics import ARM_REACH, DH, wrist_center, wrist_ik

#: The path of Figs. 5e-5h here: the main diagonal of this project's PUMA target box (frame 0, m),
#: (-0.25, 0.35, -0.30) -> (0.25, 0.75, 0.30), 0.877 m long. His START and END are only drawn
#: (Fig. 5e), in a 717 mm cube that the PUMA cannot reach entirely.
PATH_START, PATH_END = WORKSPACE_BASE_LOWER.copy(), WORKSPACE_BASE_UPPER.copy()
#: Brause's cubic workspace edge X (m): "a workspace length of 717mm".
BRAUSE_EDGE = 0.717
#: Step of the central difference (5.4), m: 10 µm, one unit of his coordinates (V_w in 1e-2 mm).
DX = 1e-5
#: His fit at the point P (5.8): e^LA = C n^b.
PAPER_B, PAPER_C = -2.65672, 2.01329
#: Neurons per dimension for the error study (his figures use n = 10 ... 1000).
N_VALUES = (5, 7, 10, 15, 20, 30, 50, 70, 100, 150, 200, 300, 500, 700, 1000)
#: V_θ of (5.9): the value range of a joint angle, rad.
V_THETA = 2 * np.pi

#: Cell border offsets in units of Δx: 8 corners and 6 face centres of the unit cube about 0.
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
BORDER = 0.5 * np.vstack([_CORNERS, np.eye(3), -np.eye(3)])  # (14, 3)

#: Storage elements per neuron: 3 w + 3 Θ + 9 A (6.1); this project's camera-input map stores
#: 4 w (pixels of two cameras) + J Θ + 4·J A.
SE_PER_NEURON_BRAUSE = 15
#: Table 6a as printed: n -> (storage elements, bytes at 3 SE = 4 bytes, bytes at 2 SE = 4 bytes).
PAPER_TABLE_6A = {
    10: (1.5e4, 20e3, 30e3),
    50: (1.87e6, 2.5e6, 3.74e6),
    100: (1.5e7, 20e6, 30e6),
    1000: (1.5e10, 20e9, 30e9),
}


def camera_map_numbers_per_neuron(joints: int = 3, inputs: int = 4) -> int:
    """Numbers per neuron of the camera-input map: w (inputs) + Θ (joints) + A (joints × inputs)."""
    return inputs + joints + inputs * joints


def storage(n: np.ndarray, per_neuron: int) -> dict[str, np.ndarray]:
    """Table 6a for n neurons per dimension (N = n³).

    Returns:
        ``neurons`` N; ``elements`` SE = per_neuron · N; ``bytes_10bit`` = SE · 4/3 (3 SE packed
        in 4 bytes, 10-bit resolution); ``bytes_12bit`` = SE · 2 (2 SE in 4 bytes, 12-bit).
    """
    n = np.asarray(n, dtype=float)
    elements = per_neuron * n**3
    return {
        "neurons": n**3,
        "elements": elements,
        "bytes_10bit": elements * 4 / 3,
        "bytes_12bit": elements * 2.0,
    }


def exact_joints(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """t(p) of Fig. 5c, right-above: (angles (..., 3), reachable with joints in range (...,))."""
    theta, reachable = wrist_ik(p, 1, 1)
    in_range = np.all((theta >= DH.lower[:3]) & (theta <= DH.upper[:3]), axis=-1)
    return theta, reachable & in_range


def central_difference(w: np.ndarray, dx: float = DX) -> np.ndarray:
    """A_c of (5.4) at cell centres w (M, 3): (M, 3, 3), rad per m, A[m, i, j] = ∂t_i/∂x_j."""
    steps = 0.5 * dx * np.eye(3)  # (3, 3): row j = dx e_j / 2
    plus = exact_joints(w[:, None, :] + steps)[0]  # (M, 3 directions, 3 joints)
    minus = exact_joints(w[:, None, :] - steps)[0]
    return np.swapaxes(plus - minus, -1, -2) / dx


def path(start: np.ndarray, end: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Straight path: (fraction s (count,), points (count, 3)) from start to end (frame 0, m)."""
    s = np.linspace(0.0, 1.0, count)
    return s, start + s[:, None] * (end - start)


def border_errors(w: np.ndarray, cell: float, dx: float = DX) -> tuple[np.ndarray, np.ndarray]:
    """Maximal linear-approximation errors on the border of cells of edge ``cell`` centred at w.

    Args:
        w: cell centres (M, 3), frame 0, m; cell: edge Δx, m.
    Returns:
        joint error (M, 3) per joint, rad; Cartesian error (M,), m. NaN where a border point or
        the centre is out of reach.
    """
    w = np.asarray(w, dtype=float)
    theta_c, ok_c = exact_joints(w)  # (M, 3)
    A = central_difference(w, dx)  # (M, 3, 3)
    x = w[:, None, :] + cell * BORDER  # (M, 14, 3)
    exact, ok = exact_joints(x)  # (M, 14, 3)
    approx = theta_c[:, None, :] + np.einsum("mij,mkj->mki", A, x - w[:, None, :])
    diff = np.angle(np.exp(1j * (exact - approx)))  # wrapped to (-π, π]
    valid = ok.all(axis=1) & ok_c
    joint = np.where(valid[:, None], np.abs(diff).max(axis=1), np.nan)
    cart = np.linalg.norm(x - wrist_center(approx), axis=-1).max(axis=1)
    return joint, np.where(valid, cart, np.nan)


def first_local_maximum(e: np.ndarray, part: float = 0.5) -> int:
    """Index of point P: the first interior local maximum of e in the first ``part`` of the path
    (Brause: "the local maximum of error in the first part of the path"); the largest value of
    that part if there is none."""
    e = np.asarray(e, dtype=float)
    stop = max(3, int(len(e) * part))
    head = e[:stop]
    interior = (head[1:-1] > head[:-2]) & (head[1:-1] >= head[2:])
    peaks = np.flatnonzero(interior) + 1
    return int(peaks[0]) if peaks.size else int(np.nanargmax(head))


def fit_power_law(n: np.ndarray, e: np.ndarray) -> tuple[float, float]:
    """Least-squares fit of lg e = a + b lg n (5.7); returns (b, C = 10^a) (5.8)."""
    b, a = np.polyfit(np.log10(np.asarray(n, dtype=float)), np.log10(np.asarray(e, dtype=float)), 1)
    return float(b), float(10.0**a)


def resolution_bits(e: np.ndarray) -> np.ndarray:
    """Minimal approximation resolution r_n = ld(V_θ / e^LA) - 1 (5.9), bits; e in rad."""
    return np.log2(V_THETA / np.asarray(e, dtype=float)) - 1.0


def train_cartesian(learner, trials: int, rng: np.random.Generator) -> int:
    """Train a map on Cartesian input by kinematic simulation of the wrist centre (5.6).

    Each trial draws a target x uniformly from the PUMA target box (frame 0), makes the coarse move
    θ0 = act(x), senses x_I = p(θ0), the fine move θ1 = act(x, x_I), senses x_F = p(θ1) and calls
    ``learn(x, θ0, x_I, θ1, x_F)``.

    Args:
        learner: anything with ``reset()``, ``act(u, v=None)`` and ``learn(u, θ0, v0, θ1, v1)``
            for 3-D input (e.g. ``learners.som.controller.VisuomotorSOM(..., input_dim=3)``).
    Returns:
        the number of trials the learner accepted.
    """
    accepted = 0
    for x in rng.uniform(WORKSPACE_BASE_LOWER, WORKSPACE_BASE_UPPER, size=(trials, 3)):
        learner.reset()
        theta0 = learner.act(x)
        v0 = wrist_center(theta0)
        theta1 = learner.act(x, v0)
        accepted += bool(learner.learn(x, theta0, v0, theta1, wrist_center(theta1)))
    return accepted


def map_errors(commands: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Errors of a learned map's commands (M, 3) for points (M, 3) (frame 0): joint error per
    joint against the exact right-above solution (rad, wrapped), and Cartesian error (m)."""
    exact, ok = exact_joints(points)
    joint = np.abs(np.angle(np.exp(1j * (commands - exact))))
    cart = np.linalg.norm(points - wrist_center(commands), axis=-1)
    return np.where(ok[:, None], joint, np.nan), np.where(ok, cart, np.nan)


#: Spacing of the slope scan's points (m) over the cube [-ARM_REACH, ARM_REACH]³ of frame 0.
SCAN_SPACING = 0.05
#: n of the slope scan: his range, 10 ... 1000.
SCAN_N = tuple(k for k in N_VALUES if k >= 10)


def slope_scan(spacing: float = SCAN_SPACING, edge: float = BRAUSE_EDGE) -> tuple[np.ndarray, ...]:
    """The fit (5.7) at every point of a regular grid over the reach cube whose cells of edge
    edge/n (every n of :data:`SCAN_N`) lie in the reachable region (right-above, joints in
    range): Brause's P is not published, so this asks where a P with his b could lie.

    Returns:
        points (K, 3) m frame 0, slopes b (K,), C (K,) rad.
    """
    axis = np.arange(-ARM_REACH, ARM_REACH + 1e-9, spacing)
    points = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3)
    points = points[exact_joints(points)[1]]
    n = np.array(SCAN_N, dtype=float)
    errors = np.array([border_errors(points, edge / k)[0].max(axis=1) for k in n])  # (n, K)
    ok = np.all(np.isfinite(errors) & (errors > 0), axis=0)
    b, a = np.polyfit(np.log10(n), np.log10(errors[:, ok]), 1)
    return points[ok], b, 10.0**a


def linear_map(w: np.ndarray, theta: np.ndarray, A: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(3.7) of a map's winner for points x (M, 3): Θ_c + A_c (x − w_c), c = argmin |x − w_k|.

    Args:
        w (N, 3), theta (N, J), A (N, J, 3): a map's arrays. Returns (M, J), rad.
    """
    c = np.argmin(((x[:, None, :] - w[None]) ** 2).sum(-1), axis=1)  # (M,)
    return theta[c] + np.einsum("mjd,md->mj", A[c], x - w[c])
