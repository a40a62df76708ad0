"""Open kinematic chains as products of elementary transforms, and their linear error model.

After Němeček, *Kinematic accuracy of a simple open chain by using automatic differentiation*:
T_0n(k) = T_Zm1(k_1) · T_Zm2(k_2) ⋯ T_ZmN(k_N) (his eq. 15), each factor a rotation about or a
translation along one axis, m ∈ {rot x, rot y, rot z, trans x, trans y, trans z}. Every chain
parameter k_j (joint angle, link length, twist, offset) is one factor. All N derivatives
∂T_0n/∂k_j come from one backward sweep Y (suffix products) and one forward sweep W (prefix
products), his Table 1:

    Y_1 = T_N,  Y_i = T_{N-i+1} Y_{i-1}          (Y_N = T_0n)
    W_N = E,    W_{N-i} = W_{N-i+1} T_i          (W_{N-j+1} = T_1 ⋯ T_{j-1})
    ∂T_0n/∂k_j = W_{N-j+1} · ∂T_Zmj/∂k_j · Y_{N-j}     (Y_0 = E)

so the cost is 3N matrix products instead of the N² of differentiating each factor in place.
For a deviation Δk, ΔT_0n = Σ_j ∂T_0n/∂k_j Δk_j (eq. 8) and the error matrices (eqs. 9-14)

    H_{n,0n} = [[Sᵀ ΔS, Sᵀ Δu], [0, 0]]   (in the end-effector frame n; = T_0n⁻¹ ΔT_0n)
    H_{0,0n} = [[ΔS Sᵀ, Δu],    [0, 0]]   (in the base frame 0, as in Table 1)

with S the rotation of T_0n, ΔS and Δu the rotation and translation blocks of ΔT_0n. The 3×3
blocks are skew-symmetric: [[0, -Δφz, Δφy], [Δφz, 0, -Δφx], [-Δφy, Δφx, 0]], small rotations.

A chain parameter may enter its factor with a sign (``sign=-1``: T_Zm(-k)), so that joints about
negative axes (RIACS θ1 about -z) keep their physical angle as k.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from models.dh import DHTable

KINDS = ("rx", "ry", "rz", "tx", "ty", "tz")  #: rotation about / translation along x, y, z
_AXIS = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class Element:
    """One factor T_Zm(sign · k) of a chain: ``kind`` in :data:`KINDS`, a parameter ``name``."""

    kind: str
    name: str
    sign: float = 1.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown elementary transform {self.kind!r}; valid: {KINDS}")
        if self.sign not in (1.0, -1.0):
            raise ValueError(f"sign of {self.name!r} must be +1 or -1, got {self.sign!r}")

    @property
    def is_rotation(self) -> bool:
        return self.kind[0] == "r"


def elementary(kind: str, value: np.ndarray, derivative: bool = False) -> np.ndarray:
    """T_Zm(value) or its derivative dT_Zm/dvalue.

    Args:
        kind: one of :data:`KINDS`.
        value: angles (rad) or lengths (m), shape (...,).
        derivative: return the derivative instead of the transform.
    Returns:
        (..., 4, 4).
    """
    if kind not in KINDS:
        raise ValueError(f"unknown elementary transform {kind!r}; valid: {KINDS}")
    value = np.asarray(value, dtype=float)
    axis = _AXIS[kind[1]]
    T = np.zeros((*value.shape, 4, 4))
    if kind[0] == "t":
        if derivative:
            T[..., axis, 3] = 1.0
        else:
            T[..., range(4), range(4)] = 1.0
            T[..., axis, 3] = value
        return T
    i, j = [a for a in range(3) if a != axis]  # the rotated plane, right-handed order
    if axis == 1:
        i, j = j, i  # rotation about y turns z towards x
    c, s = np.cos(value), np.sin(value)
    if derivative:
        c, s = -s, c
    else:
        T[..., axis, axis] = 1.0
        T[..., 3, 3] = 1.0
    T[..., i, i], T[..., i, j], T[..., j, i], T[..., j, j] = c, -s, s, c
    return T


@dataclass(frozen=True)
class Chain:
    """T_0n(k) = Π_j T_Zmj(sign_j k_j); parameters k of shape (..., N) everywhere below."""

    elements: tuple[Element, ...]

    def __len__(self) -> int:
        return len(self.elements)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(e.name for e in self.elements)

    def index(self, name: str) -> int:
        """Position of parameter ``name`` in k."""
        if name not in self.names:
            raise KeyError(f"no chain parameter {name!r}; parameters: {', '.join(self.names)}")
        return self.names.index(name)

    def _check(self, k: np.ndarray) -> np.ndarray:
        k = np.asarray(k, dtype=float)
        if k.shape[-1:] != (len(self),):
            raise ValueError(
                f"expected {len(self)} chain parameters in the last axis, got {k.shape}"
            )
        return k

    def factors(self, k: np.ndarray, derivative: bool = False) -> list[np.ndarray]:
        """The N factors T_Zmj(k_j) (or their derivatives d/dk_j), each (..., 4, 4)."""
        k = self._check(k)
        out = []
        for j, e in enumerate(self.elements):
            T = elementary(e.kind, e.sign * k[..., j], derivative)
            out.append(e.sign * T if derivative else T)
        return out

    def forward(self, k: np.ndarray) -> np.ndarray:
        """T_0n(k), shape (..., 4, 4)."""
        T = np.broadcast_to(np.eye(4), (*self._check(k).shape[:-1], 4, 4))
        for factor in self.factors(k):
            T = T @ factor
        return T

    def derivatives(self, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """T_0n and every ∂T_0n/∂k_j by the Y/W recursion of Němeček's Table 1.

        Returns:
            T_0n (..., 4, 4); derivatives (..., N, 4, 4), [..., j] = ∂T_0n/∂k_j.
        """
        factors, dfactors = self.factors(k), self.factors(k, derivative=True)
        n = len(self)
        eye = np.broadcast_to(np.eye(4), factors[0].shape)
        Y = [eye]  # Y[i] = T_{N-i+1} ⋯ T_N (1-based factors), Y[0] = E
        for i in range(1, n + 1):
            Y.append(factors[n - i] @ Y[i - 1])
        W = eye  # W_{N-j+1} = T_1 ⋯ T_{j-1}, grown as j increases
        dT = []
        for j in range(n):  # 0-based j: ∂T/∂k_j = W · dT_j · Y[N-1-j]
            dT.append(W @ dfactors[j] @ Y[n - 1 - j])
            W = W @ factors[j]
        return Y[n], np.stack(dT, axis=-3)

    def position_jacobian(self, k: np.ndarray, columns: list[int] | None = None) -> np.ndarray:
        """∂p/∂k of the chain's end point p = T_0n[:3, 3], shape (..., 3, len(columns) or N)."""
        _, dT = self.derivatives(k)
        J = np.swapaxes(dT[..., :3, 3], -1, -2)  # (..., 3, N)
        return J if columns is None else J[..., columns]

    def error_matrices(self, k: np.ndarray, dk: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Němeček's error matrices of a parameter deviation ``dk`` (eqs. 8-14, Table 1).

        Args:
            k: nominal parameters (..., N); dk: deviations (..., N), rad or m.
        Returns:
            H_{0,0n} (in the base frame) and H_{n,0n} (in the end-effector frame), each
            (..., 4, 4): rotation block = small-angle skew matrix, column 3 = position error.
        """
        T, dT = self.derivatives(k)
        delta = np.einsum("...jab,...j->...ab", dT, self._check(dk))  # ΔT_0n, eq. 8
        IY = np.swapaxes(T[..., :3, :3], -1, -2)  # Sᵀ
        DY = delta[..., :3, :3]  # ΔS
        du0 = delta[..., :3, 3]  # ⁰Δu
        H0 = np.zeros_like(delta)
        Hn = np.zeros_like(delta)
        H0[..., :3, :3] = DY @ IY
        H0[..., :3, 3] = du0
        Hn[..., :3, :3] = IY @ DY
        Hn[..., :3, 3] = np.einsum("...ab,...b->...a", IY, du0)
        return H0, Hn


def small_angles(H: np.ndarray) -> np.ndarray:
    """(Δφx, Δφy, Δφz) of an error matrix's skew block (antisymmetric part), shape (..., 3)."""
    S = 0.5 * (H[..., :3, :3] - np.swapaxes(H[..., :3, :3], -1, -2))
    return np.stack([S[..., 2, 1], S[..., 0, 2], S[..., 1, 0]], axis=-1)


def dh_chain(table: DHTable, theta: np.ndarray) -> tuple[Chain, np.ndarray]:
    """A standard-DH robot as a chain: A_i = Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i), 4 factors per joint.

    Args:
        table: the DH table (lengths m, angles rad).
        theta: joint angles (..., n), rad.
    Returns:
        the chain with parameters named ``theta<i>, d<i>, a<i>, alpha<i>`` (i = 1..n), and its
        parameter vector k, shape (..., 4n).
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape[-1:] != (table.n,):
        raise ValueError(f"expected {table.n} joint angles in the last axis, got {theta.shape}")
    elements = []
    for i in range(1, table.n + 1):
        elements += [
            Element("rz", f"theta{i}"),
            Element("tz", f"d{i}"),
            Element("tx", f"a{i}"),
            Element("rx", f"alpha{i}"),
        ]
    fixed = np.stack([table.d, table.a, table.alpha], axis=-1)  # (n, 3)
    fixed = np.broadcast_to(fixed, (*theta.shape[:-1], table.n, 3))
    k = np.concatenate([theta[..., None], fixed], axis=-1).reshape(*theta.shape[:-1], 4 * table.n)
    return Chain(tuple(elements)), k


#: RIACS arm from the structure of ``models/riacs/riacs.xml``: θ1 turns the turntable about -z,
#: θ2 pitches link 1 about x, link 1 runs along +y, θ3 pitches link 2 about x, and the tool point
#: sits at -link2 along y of link 2 (link 2 points back along link 1 at θ3 = 0).
RIACS_CHAIN = Chain(
    (
        Element("rz", "theta1", sign=-1.0),
        Element("rx", "theta2"),
        Element("ty", "link1"),
        Element("rx", "theta3"),
        Element("ty", "link2", sign=-1.0),
    )
)
RIACS_JOINTS = [0, 1, 3]  #: positions of θ1, θ2, θ3 in the RIACS chain's k


def riacs_parameters(theta: np.ndarray, link1: float, link2: float) -> np.ndarray:
    """k of :data:`RIACS_CHAIN` for joint angles theta (..., 3) (rad) and link lengths (m)."""
    theta = np.asarray(theta, dtype=float)
    ones = np.ones(theta.shape[:-1])
    t1, t2, t3 = theta[..., 0], theta[..., 1], theta[..., 2]
    return np.stack([t1, t2, link1 * ones, t3, link2 * ones], axis=-1)


@dataclass(frozen=True)
class RobotChain:
    """A robot's chain and where each segment lives in its MJCF (for the accuracy analysis,
    :mod:`models.analyses.nemecek_accuracy`).

    Attributes:
        robot: model name; chain: the chain T_0n from site ``base`` to site ``tcp``.
        joints: positions in k of the joint angles, in qpos order.
        segments: for each joint, the MJCF element ("body" or "site", name) whose local transform
            is the product of the chain's fixed factors after that joint.
        parameters: joint angles (..., J) rad -> the nominal k (..., N).
    """

    robot: str
    chain: Chain
    joints: tuple[int, ...]
    segments: tuple[tuple[str, str], ...]
    parameters: Callable[[np.ndarray], np.ndarray]

    def is_angle(self) -> np.ndarray:
        """(N,) bool: parameter is an angle (rad) rather than a length (m)."""
        return np.array([e.is_rotation for e in self.chain.elements])
