"""Open chains (Němeček): derivatives by the Y/W recursion against finite differences, the error
matrices H_{0,0n}, H_{n,0n}, both robots as chains, and the linear model against MuJoCo."""

import json

import numpy as np
import pytest

from envs.cli import kinematic_accuracy
from models import load_model, puma560, riacs
from models.analyses import nemecek_accuracy as acc
from models.chain import (
    KINDS,
    RIACS_CHAIN,
    Chain,
    Element,
    dh_chain,
    elementary,
    riacs_parameters,
    small_angles,
)


def explicit(kind: str, v: float) -> np.ndarray:
    """Elementary transforms written out."""
    c, s = np.cos(v), np.sin(v)
    T = np.eye(4)
    if kind == "rx":
        T[1:3, 1:3] = [[c, -s], [s, c]]
    elif kind == "ry":
        T[0, 0], T[0, 2], T[2, 0], T[2, 2] = c, s, -s, c
    elif kind == "rz":
        T[0:2, 0:2] = [[c, -s], [s, c]]
    else:
        T["xyz".index(kind[1]), 3] = v
    return T


def central_difference(chain: Chain, k: np.ndarray, h: float) -> np.ndarray:
    """∂T/∂k_j for every j, (N, 4, 4)."""
    eye = np.eye(len(k))
    return np.stack([(chain.forward(k + h * e) - chain.forward(k - h * e)) / (2 * h) for e in eye])


@pytest.mark.parametrize("kind", KINDS)
def test_elementary_transforms_and_derivatives(kind):
    for v in (-2.0, 0.3, 1.1):
        np.testing.assert_allclose(elementary(kind, v), explicit(kind, v), atol=1e-15)
        h = 1e-6
        numeric = (explicit(kind, v + h) - explicit(kind, v - h)) / (2 * h)
        np.testing.assert_allclose(elementary(kind, v, derivative=True), numeric, atol=1e-9)


def random_chain(rng: np.random.Generator, n: int) -> tuple[Chain, np.ndarray]:
    kinds = rng.choice(KINDS, size=n)
    signs = rng.choice([-1.0, 1.0], size=n)
    chain = Chain(
        tuple(
            Element(str(k), f"k{i}", float(s))
            for i, (k, s) in enumerate(zip(kinds, signs, strict=True))
        )
    )
    return chain, rng.uniform(-1.5, 1.5, size=n)


@pytest.mark.parametrize("seed", range(4))
def test_every_derivative_equals_a_central_difference(seed):
    rng = np.random.default_rng(seed)
    chains = [
        random_chain(rng, 9),
        dh_chain(puma560.DH, rng.uniform(-2, 2, 6)),
        (RIACS_CHAIN, riacs_parameters(rng.uniform(0.1, 1.4, 3), 0.6, 0.4)),
    ]
    for chain, k in chains:
        T, dT = chain.derivatives(k)
        np.testing.assert_allclose(T, chain.forward(k), atol=1e-14)
        numeric = central_difference(chain, k, 1e-5)
        scale = np.maximum(np.abs(numeric), 1.0)  # relative, entries of size ~1 m or 1
        assert np.max(np.abs(dT - numeric) / scale) < 1e-6


def test_derivatives_are_vectorised_over_a_batch():
    rng = np.random.default_rng(5)
    theta = rng.uniform(-2, 2, size=(4, 3, 6))
    chain, k = dh_chain(puma560.DH, theta)
    _, dT = chain.derivatives(k)
    assert dT.shape == (4, 3, 24, 4, 4)
    one = chain.derivatives(k[2, 1])[1]
    np.testing.assert_allclose(dT[2, 1], one, atol=1e-15)


def test_puma_chain_reproduces_frames_and_riacs_chain_reproduces_robot3df():
    rng = np.random.default_rng(6)
    theta = rng.uniform(puma560.DH.lower, puma560.DH.upper, size=(50, 6))
    chain, k = dh_chain(puma560.DH, theta)
    np.testing.assert_allclose(chain.forward(k), puma560.frames(theta)[:, 6], atol=1e-14)
    angles = rng.uniform(riacs.LOWER, riacs.UPPER, size=(50, 3))
    tip = RIACS_CHAIN.forward(riacs_parameters(angles, riacs.LINK1, riacs.LINK2))[:, :3, 3]
    expected = np.stack(riacs.robot3df(0.6, 0.4, *angles.T), axis=-1)
    np.testing.assert_allclose(tip, expected, atol=1e-14)


def true_error(chain: Chain, k: np.ndarray, dk: np.ndarray) -> np.ndarray:
    """T⁻¹ (T(k + Δk) - T(k)), the exact pose error in the end-effector frame."""
    T = chain.forward(k)
    return np.linalg.solve(T, chain.forward(k + dk) - T)


def test_error_matrix_is_second_order_accurate():
    rng = np.random.default_rng(7)
    chain, k = dh_chain(puma560.DH, rng.uniform(-2, 2, 6))
    direction = rng.normal(size=len(k))
    misses = []
    for size in (1e-3, 1e-4):
        dk = size * direction
        H0, _ = chain.error_matrices(k, dk)
        actual = chain.forward(k + dk)[:3, 3] - chain.forward(k)[:3, 3]
        misses.append(np.linalg.norm(H0[:3, 3] - actual))
    assert 70 < misses[0] / misses[1] < 130  # 10× smaller deviation, about 100× smaller miss


def test_error_matrices_in_both_frames():
    rng = np.random.default_rng(8)
    chain, k = dh_chain(puma560.DH, rng.uniform(-2, 2, 6))
    dk = 1e-7 * rng.normal(size=len(k))
    H0, Hn = chain.error_matrices(k, dk)
    # Eq. 10: H_n = T⁻¹ ΔT; the exact error agrees to first order.
    exact = true_error(chain, k, dk)
    np.testing.assert_allclose(Hn, exact, atol=1e-12)
    # The rotation blocks are skew-symmetric: exactly for the linear model ...
    for H in (H0, Hn):
        np.testing.assert_allclose(H[:3, :3], -H[:3, :3].T, atol=1e-20)
        np.testing.assert_array_equal(H[3], 0.0)
    # ... and to first order for the exact error (symmetric part is second order).
    direction = rng.normal(size=len(k))
    sym, skew = [], []
    for size in (1e-3, 1e-4):
        E = true_error(chain, k, size * direction)[:3, :3]
        sym.append(np.max(np.abs(E + E.T)))
        skew.append(np.max(np.abs(E - E.T)))
    assert 70 < sym[0] / sym[1] < 130 and 9 < skew[0] / skew[1] < 11
    # Base and end-effector frames: ΔΘ_0 = S ΔΘ_n Sᵀ, ⁿΔu = Sᵀ ⁰Δu.
    S = chain.forward(k)[:3, :3]
    np.testing.assert_allclose(H0[:3, :3], S @ Hn[:3, :3] @ S.T, atol=1e-20)
    np.testing.assert_allclose(Hn[:3, 3], S.T @ H0[:3, 3], atol=1e-20)
    # The small angles of a pure rotation about z0 by ε at the base are (0, 0, ε) in frame 0.
    H0z, _ = chain.error_matrices(k, 1e-6 * (np.arange(len(k)) == 0))
    np.testing.assert_allclose(small_angles(H0z), [0, 0, 1e-6], atol=1e-18)


@pytest.mark.parametrize("robot", ["puma560", "riacs"])
def test_perturbed_mjcf_reproduces_the_model_and_the_linear_model_is_second_order(robot):
    rc = acc.robot_chain(robot)
    rng = np.random.default_rng(9)
    J = 6 if robot == "puma560" else 3
    lower, upper = (puma560.DH.lower, puma560.DH.upper) if J == 6 else (riacs.LOWER, riacs.UPPER)
    theta = rng.uniform(lower, upper)
    k = rc.parameters(theta)
    original = acc.tool_pose(load_model(robot, scene=False), theta)
    rebuilt = acc.tool_pose(acc.perturbed_model(rc, k, np.zeros(len(k))), theta)
    np.testing.assert_allclose(rebuilt, original, atol=1e-12)
    np.testing.assert_allclose(rc.chain.forward(k), original, atol=1e-12)
    # A length deviation Δ along the chain moves the tool by exactly |Δ| in MuJoCo.
    lengths = np.flatnonzero(~rc.is_angle())
    dk = np.zeros(len(k))
    dk[lengths[0]] = 1e-3
    moved = acc.tool_pose(acc.perturbed_model(rc, k, dk), theta)
    assert np.linalg.norm(moved[:3, 3] - original[:3, 3]) == pytest.approx(1e-3, rel=1e-9)
    small, big = (
        acc.check_linear_model(rc, theta, level, np.random.default_rng(1))
        for level in (0.001, 0.01)
    )
    ratio = np.linalg.norm(big.all_predicted - big.all_actual) / np.linalg.norm(
        small.all_predicted - small.all_actual
    )
    assert 70 < ratio < 130
    # The prediction catches the bulk of the error.
    assert np.linalg.norm(big.all_predicted - big.all_actual) < 0.05 * np.linalg.norm(
        big.all_actual
    )


def test_accuracy_script_writes_sensitivities(tmp_path):
    kinematic_accuracy.main(["--robot", "riacs", "--out", str(tmp_path)])
    result = json.loads((tmp_path / "accuracy.json").read_text())
    dp = np.array(result["sensitivity_dp_per_unit"])
    names = result["parameters"]
    # Link lengths move the tool point 1:1; θ1 about the vertical moves it by the radius r.
    assert np.linalg.norm(dp[names.index("link1")]) == pytest.approx(1.0)
    assert np.linalg.norm(dp[names.index("link2")]) == pytest.approx(1.0)
    x, y, _ = riacs.robot3df(0.6, 0.4, *riacs.HOME)
    assert np.linalg.norm(dp[names.index("theta1")]) == pytest.approx(np.hypot(x, y))
