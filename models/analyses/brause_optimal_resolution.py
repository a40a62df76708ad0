"""Brause (1989) §6.2 and appendix B: positioning error against storage, and the optimal split of
the storage between the number of neurons and the bits of w_c, Θ_c and A_c.

Errors are per joint, in rad (his e^LA is the joint error of Fig. 5i); lengths in m, A in rad/m
(his 1e-2 mm units converted: V_A = 2.0e-4 rad per 1e-2 mm = 20 rad/m, S_A = 1.0e-5 = 1 rad/m).

    inc_z = V_z / 2^r_z                                                  (B.5)
    e_i^RES = ½ inc_θ + (3/2) inc_A X/(2n) + ½ inc_w S_A + (3/2) inc_A ½ inc_w      (B.4)
    e_i^MAX = e^LA + e_i^RES,  e^LA = C n^b (5.8),  e^MAX = √3 e_i^MAX    (6.2, B.1 and its note)
    s = n³ (3 r_w + 3 r_θ + 9 r_A) bits                                   (6.1)

The optimum (6.4): the four terms ∂e/∂x · ∂x/∂s of (B.2)-(B.3) equal. term4 = term2 gives (B.7)
inc_A = inc_w S_A / (X/(2n) − inc_w), term3 = term2 gives (B.8) inc_θ = inc_w (S_A + 3/2 inc_A),
and term3 = term1 gives g(n, r_w) = 0, solved for n by Newton's method. Readings of g (the
extracted (B.6) is garbled; see :data:`READINGS`):

    "derived":   g = (3/2) inc_A X/(2n) − b C n^b − (3/2) ln2 inc_θ R,  R = r_w + r_θ + 3 r_A
                 what (B.2)-(B.3) give, with the factor b of d(C n^b)/dn = b C n^(b−1). This is
                 the stationarity condition of e^MAX at fixed s: its solution is the true minimum.
    "printed":   the same without b, as extracted. Then g < 0 for every n (all three terms
                 but the tiny first are negative): there is no optimum.
    "published": with b, but ln2 where the derivation has (3/2) ln2. This reproduces every
                 number Brause prints (n = 39.6, r_θ = 20.1, r_A = 15 at r_w = 17, 1.9 MB,
                 equal r = 16.4, 18 % less error); a hypothesis about his computation.

"Equal resolutions" (his comparison curve): the optimum's n with r_w = r_θ = r_A = s/(15 n³),
his "optimized n, but equal resolutions" (his 39.6³ neurons at 16.4 bits are the optimum's n).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.analyses.brause_linear_error import BRAUSE_EDGE, PAPER_B, PAPER_C, V_THETA
from models.puma560.kinematics import wrist_center

#: V_A of appendix B, "2.0e-4 on the linear path of section 5" per 1e-2 mm: rad/m.
PAPER_V_A = 20.0
#: S_A := max_i Σ_j A_ij "= 1.0e-5 for the PUMA configuration in point P", per 1e-2 mm: rad/m.
PAPER_S_A = 1.0
#: Bits per byte (his MB: 1e6 bytes; 1.9 MB = 1.52e7 bits).
BITS_PER_BYTE = 8
#: The numbers §6.2 prints: the equal-resolution and optimal configurations at 1.9 MB, and the
#: ratio of their Cartesian errors at 1.13e14 bytes.
PUBLISHED = {
    "n": 39.6,
    "r_equal": 16.4,
    "r_w": 17.0,
    "r_theta": 20.1,
    "r_A": 15.0,
    "storage_bytes": 1.9e6,
    "e_equal_mm": 0.201,
    "e_opt_mm": 0.164,
    "big_storage_bytes": 1.13e14,
    "big_ratio": 5.6,
}
#: g readings: (multiply C n^b by b, factor of ln2 inc_θ R).
READINGS = {"derived": (True, 1.5), "printed": (False, 1.5), "published": (True, 1.0)}
#: Newton stops when a step changes n by less than this, relative.
NEWTON_TOL = 1e-13


@dataclass(frozen=True)
class ErrorModel:
    """e^LA = C n^b (rad) and the ranges of the stored variables (B.5).

    Args:
        b, C: fit (5.8), C in rad. X: workspace edge (m) = V_w. V_theta: rad. V_A, S_A: rad/m.
    """

    b: float = PAPER_B
    C: float = PAPER_C
    X: float = BRAUSE_EDGE
    V_theta: float = V_THETA
    V_A: float = PAPER_V_A
    S_A: float = PAPER_S_A

    def e_la(self, n):
        return self.C * np.asarray(n, dtype=float) ** self.b

    def e_res(self, n, r_w, r_theta, r_A):
        """(B.4): per-joint error of the stored values rounded to r bits, rad."""
        inc_w, inc_t, inc_A = self.X / 2.0**r_w, self.V_theta / 2.0**r_theta, self.V_A / 2.0**r_A
        half_cell = self.X / (2 * np.asarray(n, dtype=float))
        return 0.5 * inc_t + 1.5 * inc_A * half_cell + 0.5 * inc_w * self.S_A + 0.75 * inc_A * inc_w

    def e_joint(self, n, r_w, r_theta, r_A):
        """e_i^MAX = e^LA + e_i^RES, rad (the same for every joint i)."""
        return self.e_la(n) + self.e_res(n, r_w, r_theta, r_A)

    def e_max(self, n, r_w, r_theta, r_A):
        """(B.1): e^MAX = √3 e_i^MAX, rad."""
        return np.sqrt(3.0) * self.e_joint(n, r_w, r_theta, r_A)


def storage_bits(n, r_w, r_theta, r_A):
    """(6.1): s = n³ (3 r_w + 3 r_θ + 9 r_A), bits."""
    return np.asarray(n, dtype=float) ** 3 * (3 * r_w + 3 * r_theta + 9 * r_A)


@dataclass(frozen=True)
class Config:
    """n neurons per dimension and the bits of w, Θ, A."""

    n: float
    r_w: float
    r_theta: float
    r_A: float

    @property
    def bits(self) -> float:
        return float(storage_bits(self.n, self.r_w, self.r_theta, self.r_A))

    def equal(self) -> Config:
        """Same n and storage, equal resolutions r = s / (15 n³)."""
        r = self.bits / (15 * self.n**3)
        return Config(self.n, r, r, r)


def resolutions(model: ErrorModel, n, r_w):
    """(B.7), (B.8): r_θ and r_A (bits) that balance r_w at n."""
    inc_w = model.X / 2.0**r_w
    inc_A = inc_w * model.S_A / (model.X / (2 * n) - inc_w)
    inc_t = inc_w * (model.S_A + 1.5 * inc_A)
    return np.log2(model.V_theta / inc_t), np.log2(model.V_A / inc_A)


def g(model: ErrorModel, n, r_w, reading: str = "derived"):
    """g(n, r_w) of (B.6) in the given reading (see :data:`READINGS`), rad."""
    with_b, factor = READINGS[reading]
    r_t, r_A = resolutions(model, n, r_w)
    inc_A, inc_t = model.V_A / 2.0**r_A, model.V_theta / 2.0**r_t
    cn = model.e_la(n) * (model.b if with_b else 1.0)
    return 1.5 * inc_A * model.X / (2 * n) - cn - factor * np.log(2) * inc_t * (r_w + r_t + 3 * r_A)


def solve_n(model: ErrorModel, r_w: float, reading: str = "derived") -> float:
    """n_opt(r_w): the first zero of g on n ≥ 1 with r_A ≥ 0 (where g falls through 0), by
    Newton's method (central-difference derivative) kept inside a sign-change bracket.

    Raises:
        ValueError: g has no zero there (the "printed" reading).
    """
    inc_w = model.X / 2.0**r_w
    n_max = model.X / (2 * inc_w * (1 + model.S_A / model.V_A))  # r_A = 0 from (B.7)
    grid = np.geomspace(1.0, n_max, 400)
    values = g(model, grid, r_w, reading)
    change = np.flatnonzero((values[:-1] > 0) & (values[1:] <= 0))
    if change.size == 0:
        raise ValueError(f"g(n, r_w={r_w}) of reading {reading!r} has no zero for 1 <= n <= n_max")
    lo, hi = grid[change[0]], grid[change[0] + 1]
    n = 0.5 * (lo + hi)
    for _ in range(200):
        gn = g(model, n, r_w, reading)
        lo, hi = (n, hi) if gn > 0 else (lo, n)
        h = 1e-6 * n
        slope = (g(model, n + h, r_w, reading) - g(model, n - h, r_w, reading)) / (2 * h)
        step = n - gn / slope if slope < 0 else 0.5 * (lo + hi)
        new = step if lo < step < hi else 0.5 * (lo + hi)
        if abs(new - n) <= NEWTON_TOL * n:
            return float(new)
        n = new
    return float(n)


def optimum(model: ErrorModel, r_w: float, reading: str = "derived") -> Config:
    """The optimal configuration for a given r_w (what Fig. B.1 plots against its storage)."""
    n = solve_n(model, r_w, reading)
    r_t, r_A = resolutions(model, n, r_w)
    return Config(n, float(r_w), float(r_t), float(r_A))


def optimum_for_storage(model: ErrorModel, bits: float, reading: str = "derived") -> Config:
    """The optimal configuration of ``bits`` storage (bisection on r_w; s grows with r_w)."""
    lo, hi = 2.0, 80.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if optimum(model, mid, reading).bits < bits else (lo, mid)
    return optimum(model, 0.5 * (lo + hi), reading)


def grid_minimum(model: ErrorModel, bits: float, start: Config, rounds: int = 30) -> Config:
    """Brute force: minimum of e^MAX over (n, r_w, r_θ) with r_A from the storage, on a 41³
    grid around ``start`` that shrinks by 2 each round (independent of g and Newton)."""
    centre, span = np.array([np.log(start.n), start.r_w, start.r_theta]), np.array([0.3, 3, 3])
    axes = np.linspace(-1.0, 1.0, 41)
    for _ in range(rounds):
        ln_n, r_w, r_t = (c + s * axes for c, s in zip(centre, span, strict=True))
        n = np.exp(ln_n)[:, None, None]
        r_w, r_t = r_w[None, :, None], r_t[None, None, :]
        r_A = (bits / n**3 - 3 * r_w - 3 * r_t) / 9
        e = np.where(r_A > 0, model.e_max(n, r_w, r_t, np.maximum(r_A, 1e-9)), np.inf)
        i, j, k = np.unravel_index(np.argmin(e), e.shape)
        centre = np.array([ln_n[i], r_w[0, j, 0], r_t[0, 0, k]])
        span = span / 2
    n = float(np.exp(centre[0]))
    return Config(n, centre[1], centre[2], (bits / n**3 - 3 * centre[1] - 3 * centre[2]) / 9)


def cartesian_error(theta: np.ndarray, e_joint) -> np.ndarray:
    """Cartesian error of a per-joint error e at joints θ (3,): max over the 8 sign patterns σ
    of |p(θ + e σ) − p(θ)| with p the wrist centre (5.6), m. e: scalar or array."""
    e = np.asarray(e_joint, dtype=float)[..., None, None]
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    moved = wrist_center(theta[:3] + e * signs)  # (..., 8, 3)
    return np.linalg.norm(moved - wrist_center(theta[:3]), axis=-1).max(axis=-1)
