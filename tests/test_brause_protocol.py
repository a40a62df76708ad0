"""Brause's own protocol (§3): coarse Θ_c, fine (3.7), learning (3.9)/(3.10) as printed with the
step neighbourhood (3.2) and one rate satisfying (3.3); the trial loop and checkpoints."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from envs.harness.trials import run_trial
from learners.som.controller import VisuomotorSOM
from learners.som.lattice import Lattice
from learners.som.schedules import harmonic

from helpers import SMALL_COORDS as COORDS
from helpers import hand_set_map

LOW, HIGH = np.array([-3.0, -3.0]), np.array([3.0, 3.0])


def small_map(**kw) -> VisuomotorSOM:
    return hand_set_map(LOW, HIGH, protocol="brause", **kw)


def test_coarse_command_is_the_winners_theta_exactly():
    som = small_map(sigma_out=5.0)  # a wide output neighbourhood must not matter
    u = np.array([1.2, 0.1])  # winner: neuron 2 at (1, 0)
    assert np.array_equal(som.act(u), som.theta[2])
    assert np.array_equal(som.act_batch(u[None]), som.theta[2][None])


def test_fine_command_is_3_7_whatever_was_sensed():
    som = small_map()
    x = np.array([1.2, 0.1])
    som.act(x)
    expected = som.theta[2] + som.A[2] @ (x - som.w[2])  # Θ_c + A_c (x − w_c)
    for sensed in ([1.0, 0.3], [5.0, -4.0], [np.nan, np.nan]):
        np.testing.assert_allclose(som.act(x, sensed), expected, rtol=0, atol=1e-15)


def test_one_learning_step_is_3_9_and_3_10_as_printed():
    radius, t_max = 1.0, 100
    som = small_map(sigma=radius, gamma=(0.5, 0.05), t_max=t_max)
    x, x_i, x_f = np.array([1.2, 0.1]), np.array([1.0, 0.3]), np.array([1.15, 0.12])
    c = 2  # winner at lattice (1, 0)
    w, th, A = som.w.copy(), som.theta.copy(), som.A.copy()
    theta0, theta1 = th[c].copy(), th[c] + A[c] @ (x - w[c])  # the commands of his protocol
    theta_star = th[c] + A[c] @ (x - x_f)  # (3.9)
    d = x_f - x_i
    A_star = A[c] + np.outer(A[c] @ ((x - x_f) - (w[c] - x_i)), d) / (d @ d)  # (3.10)
    gamma = 0.5  # γ(0) = γ_i
    for k, y in enumerate(COORDS):
        h = 1.0 if np.hypot(y[0] - 1, y[1] - 0) <= radius else 0.0  # (3.2), step
        w[k] += gamma * h * (x - w[k])
        th[k] += gamma * h * (theta_star - th[k])
        A[k] += gamma * h * (A_star - A[k])
    assert som.learn(x, theta0, x_i, theta1, x_f)
    np.testing.assert_allclose(som.w, w, atol=1e-15)
    np.testing.assert_allclose(som.theta, th, atol=1e-15)
    np.testing.assert_allclose(som.A, A, atol=1e-14)
    # only the neurons with |y_k − y_c| ≤ 1 moved (not those at distance √2)
    moved = np.any(som.w != np.array(COORDS, float), axis=1)
    assert moved.tolist() == [True, False, True, True, True, False]


def test_3_10_is_the_widrow_hoff_step_of_the_commands_sent():
    # With θ1 − θ0 = A_c (x − w_c), (3.10) makes A* (x_F − x_I) = θ1 − θ0 exactly.
    som = small_map(gamma=(1.0, 0.5), sigma=0.5)
    x, x_i, x_f = np.array([1.2, 0.1]), np.array([1.0, 0.3]), np.array([1.4, -0.2])
    theta0 = som.act(x)
    theta1 = som.act(x, x_i)
    som.learn(x, theta0, x_i, theta1, x_f)  # γ = 1 at t = 0: A_c := A*
    np.testing.assert_allclose(som.A[2] @ (x_f - x_i), theta1 - theta0, atol=1e-14)


def test_step_neighbourhood_matches_a_loop_over_the_lattice():
    lattice = Lattice((5, 4, 3))
    coords = [np.array(c) for c in itertools.product(range(5), range(4), range(3))]
    for s, radius in ((0, 0.5), (17, 1.0), (31, 1.5), (59, 2.3), (7, 99.0)):
        got = sorted(lattice.within(s, radius).tolist())
        want = [k for k, c in enumerate(coords) if np.linalg.norm(c - coords[s]) <= radius]
        assert got == want


def test_harmonic_rate_satisfies_3_3_and_meets_the_schedule_ends():
    assert harmonic(1.0, 0.005, 0, 1000) == 1.0
    assert harmonic(1.0, 0.005, 1000, 1000) == pytest.approx(0.005)
    t = np.arange(0, 10**6, 1000)
    g = np.array([harmonic(1.0, 0.005, k, 1000) for k in t])
    assert np.all(np.diff(g) < 0) and g[-1] < 1e-5  # no floor: γ → 0 like 1/t
    with pytest.raises(ValueError, match="initial >= final"):
        VisuomotorSOM(LOW, HIGH, lattice=(3, 2), input_dim=2, protocol="brause", gamma=(0.1, 0.2))


def test_unknown_protocol_names_the_valid_ones():
    with pytest.raises(ValueError, match="mrs, brause"):
        VisuomotorSOM(LOW, HIGH, lattice=(3, 2), input_dim=2, protocol="ritter")


def test_protocol_survives_save_and_load(tmp_path):
    som = small_map()
    path = som.save(tmp_path / "m.npz")
    assert VisuomotorSOM.load(path).protocol == "brause"


class _BlindEnv:
    """A stand-in env: the marker is not seen after the coarse move, seen after the fine one."""

    def __init__(self):
        self.unwrapped, self.moves = self, 0

    def reset(self, options=None):
        self.moves = 0
        return None, {"target_pos": np.zeros(3)}

    def sensed_target(self):
        return np.array([1.2, 0.1])

    def sensed_effector(self):
        return np.full(2, np.nan) if self.moves == 1 else np.array([1.1, 0.1])

    def step(self, command):
        self.moves += 1
        info = {"distance": 0.01, "pixel_error": 1.0, "visible": self.moves != 1}
        return None, 0.0, False, False, info | {"effector_pos": np.zeros(3)}


def test_brause_trials_go_on_when_a_marker_is_not_seen_mrs_trials_stop():
    som = small_map()
    trial = run_trial(_BlindEnv(), som, fine_moves=2)  # the map's protocol: brause
    assert len(trial.commands) == 3 and trial.visible == [False, True, True]
    np.testing.assert_array_equal(trial.commands[1], trial.commands[2])  # (3.7) again
    assert not som.learn(trial.target_px, trial.commands[0], trial.sensed_px[0],
                         trial.commands[1], trial.sensed_px[1])  # fmt: skip
    assert som.skipped["not_visible"] == 1
    som = som.with_config(protocol="mrs")
    assert len(run_trial(_BlindEnv(), som, fine_moves=2).commands) == 1


def test_a_clipped_fine_command_is_learned_as_sent():
    # The joint range stops the fine command: A* must map the sensed move onto the move made.
    som = small_map(gamma=(1.0, 0.5), sigma=0.5)
    som.A = som.A * 20  # fine move far beyond the ±3 rad range
    x, x_i, x_f = np.array([1.2, 0.1]), np.array([1.0, 0.3]), np.array([1.4, -0.2])
    theta0, theta1 = som.act(x), som.act(x, x_i)
    assert np.any(np.abs(theta1) == 3.0)  # clipped
    som.learn(x, theta0, x_i, theta1, x_f)
    np.testing.assert_allclose(som.A[2] @ (x_f - x_i), theta1 - theta0, atol=1e-13)


def test_without_exploration_3_10_only_right_multiplies_a_c():
    # The fine move is Δθ = A_c e, e = x − w_c, so (3.10) is A* = A_c (I + (e − Δv) Δv^T/|Δv|²):
    # A* maps into the range of A_c, whatever is sensed. A direction of joint space that A_c
    # misses (or, with an A_c J of the wrong sign, moves the wrong way) is never corrected by
    # the protocol's own trials; this is why it needs well-excited A_c (see
    # learners/som/controller.py).
    som = small_map(gamma=(1.0, 0.5), sigma=0.5)  # γ = 1 at t = 0: A_c := A*, winner only
    som.A = np.array([np.outer([1.0, 2.0], [0.5, -1.0])] * 6)  # rank 1, range along (1, 2)
    x, x_i, x_f = np.array([1.2, 0.1]), np.array([1.0, 0.3]), np.array([1.4, -0.7])
    a_c, e = som.A[2].copy(), x - som.w[2]
    theta0, theta1 = som.act(x), som.act(x, x_i)
    som.learn(x, theta0, x_i, theta1, x_f)
    d = x_f - x_i
    np.testing.assert_allclose(som.A[2], a_c @ (np.eye(2) + np.outer(e - d, d) / (d @ d)))
    across = np.array([2.0, -1.0]) / np.sqrt(5.0)  # orthogonal to the range of A_c
    assert np.abs(across @ som.A[2]).max() < 1e-14
    assert abs(across @ (som.theta[2] - theta0)) < 1e-14  # Θ* moves only along it too
