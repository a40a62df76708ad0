"""NATEnet: allocation rule, width reset, delta rule, convergence, persistence, bad input.

Expected values are computed here by hand or with formulas written independently of the module.
"""

from __future__ import annotations

import numpy as np
import pytest

from learners.natenet import NATEnet, PathTracker, grid_counts
from learners.persistence import CheckpointError


def hand_output(centres, widths, outputs, x):
    """Σ Y_i a_i / Σ a_i with a_i = exp(-‖x - x_i‖²/σ_i²), written out with a Python loop."""
    num, den = np.zeros(outputs.shape[1:]), 0.0
    for c, s, y in zip(centres, widths, outputs, strict=True):
        a = np.exp(-np.sum((np.asarray(x) - c) ** 2) / s**2)
        num, den = num + a * y, den + a
    return num / den


def two_node_net(**kwargs) -> NATEnet:
    """Nodes at (0, 0) (σ 1) and (3, 0) (σ 2) with known 2×2 outputs; constant T_e = 0.2."""
    params = dict(input_dim=2, output_shape=(2, 2), lam=0.8, eta=0.5, T0=0.2, e_f=0.2, T_a=0.5)
    net = NATEnet(**{**params, **kwargs})
    net.centres = np.array([[0.0, 0.0], [3.0, 0.0]])
    net.widths = np.array([1.0, 2.0])
    net.outputs = np.array([[[1.0, 0.0], [0.0, 2.0]], [[0.5, 1.0], [-1.0, 1.0]]])
    return net


def move_with_error(net: NATEnet, x, dx, relative: float):
    """A joint move whose prediction error ‖E‖/‖Δθ‖ equals ``relative`` exactly."""
    M = hand_output(net.centres, net.widths, net.outputs, x)
    predicted = M @ dx
    # Δθ = predicted + E with E ⊥ predicted: ‖E‖/‖Δθ‖ = r  <=>  ‖E‖ = r‖pred‖/sqrt(1 - r²)
    perp = np.array([-predicted[1], predicted[0]]) / np.linalg.norm(predicted)
    return predicted + perp * relative * np.linalg.norm(predicted) / np.sqrt(1 - relative**2)


# x = (1, 0): a = (e^-1, e^-1) = 0.368 < T_a; x = (0.2, 0): a_1 = e^-0.04 = 0.96 > T_a.
QUIET, BUSY = np.array([1.0, 0.0]), np.array([0.2, 0.0])
DX = np.array([0.3, -0.4])


@pytest.mark.parametrize(
    ("x", "relative", "expected"),
    [(QUIET, 0.5, True), (QUIET, 0.1, False), (BUSY, 0.5, False), (BUSY, 0.1, False)],
)
def test_allocation_exactly_when_both_conditions_hold(x, relative, expected):
    net = two_node_net()
    result = net.learn(x, move_with_error(net, x, DX, relative), DX)
    assert result.error == pytest.approx(relative, rel=1e-9)
    assert result.allocated is expected
    assert net.n_nodes == 2 + expected


def test_no_allocation_when_budget_used_or_disabled():
    for net in (two_node_net(max_nodes=2), two_node_net(allocate=False)):
        assert not net.learn(QUIET, move_with_error(net, QUIET, DX, 0.9), DX).allocated
        assert net.n_nodes == 2


def test_allocation_resets_widths_and_makes_the_net_right_at_x():
    net = two_node_net()
    dtheta = move_with_error(net, QUIET, DX, 0.5)
    net.learn(QUIET, dtheta, DX)
    # By hand, λ = 0.8: distances from (1, 0) are 1 and 2, so σ_N = 0.8·1 = 0.8 and the old
    # widths become 0.8·min(1/0.8, 1) = 0.8 and 0.8·min(2/0.8, 2) = 1.6.
    np.testing.assert_allclose(net.widths, [0.8, 1.6, 0.8])
    np.testing.assert_array_equal(net.centres[-1], QUIET)
    np.testing.assert_allclose(net.predict(QUIET) @ DX, dtheta, atol=1e-12)


def test_width_of_a_far_node_is_kept():
    net = two_node_net(T_a=0.9)
    x = np.array([0.0, 0.9])  # a_1 = e^-0.81 = 0.44, distance 0.9 < 1/0.8: node 1 shrinks
    net.learn(x, move_with_error(net, x, DX, 0.5), DX)
    far = np.hypot(3.0, 0.9)  # 3.13 > 2/0.8: node 2 keeps σ = 2
    np.testing.assert_allclose(net.widths, [0.8 * 0.9, 2.0, 0.8 * 0.9])
    assert far > 2.0 / 0.8


def test_first_node_uses_sigma_init_and_reproduces_the_move():
    net = NATEnet(input_dim=2, output_shape=(2, 2), sigma_init=0.3)
    assert net.learn(QUIET, [0.1, 0.2], DX).allocated
    np.testing.assert_allclose(net.widths, [0.3])
    np.testing.assert_allclose(net.predict(np.array([5.0, 5.0])) @ DX, [0.1, 0.2])


def test_every_width_is_lambda_times_the_nearest_centre_distance_first_node_included():
    net = NATEnet(input_dim=2, output_shape=(2, 2))
    assert net.learn(np.zeros(2), [0.1, 0.2], DX).allocated
    x = np.array([1.0, 0.0])
    assert net.learn(x, move_with_error(net, x, DX, 0.9), DX).allocated
    np.testing.assert_allclose(net.widths, [0.87, 0.87])
    for x in ([3.0, 0.0], [3.0, 2.5], [-2.0, 1.5]):
        x = np.array(x)
        assert net.learn(x, move_with_error(net, x, DX, 0.9), DX).allocated
    gaps = np.linalg.norm(net.centres[:, None] - net.centres[None], axis=-1)  # (N, N)
    np.fill_diagonal(gaps, np.inf)
    np.testing.assert_allclose(net.widths, 0.87 * gaps.min(axis=1))


def test_one_delta_rule_step_equals_hand_computation():
    net = two_node_net()
    x, dtheta = BUSY, np.array([0.7, -0.2])
    old = net.outputs.copy()
    assert not net.learn(x, dtheta, DX).allocated
    a = np.array([np.exp(-0.04 / 1.0), np.exp(-(2.8**2) / 4.0)])
    M = (a[0] * old[0] + a[1] * old[1]) / a.sum()
    e = np.outer(dtheta - M @ DX, DX) / (DX @ DX)  # normalised LMS error of the output matrix
    expected = old + 0.5 * (a / a.sum())[:, None, None] * e
    np.testing.assert_allclose(net.outputs, expected, rtol=1e-12)


def test_error_threshold_decays_to_e_f():
    net = NATEnet(T0=0.9, e_f=0.1, tau=100.0)
    assert net.error_threshold(0) == pytest.approx(0.9)
    assert net.error_threshold(100) == pytest.approx(0.8 / np.e + 0.1)
    assert net.error_threshold(1e6) == pytest.approx(0.1)


def smooth_map(x: np.ndarray) -> np.ndarray:
    """A smooth 3×3 matrix field of 2 inputs: θ̇ = M*(x)·ẋ."""
    return np.array(
        [
            [1 + 0.3 * np.sin(x[0]), 0.2 * x[1], 0.1],
            [0.0, 2 - 0.5 * np.cos(x[1]), 0.3 * x[0] * x[1]],
            [0.4, -0.1, 1.5 + 0.2 * np.sin(x[0] + x[1])],
        ]
    )


def test_net_learns_a_smooth_linear_in_xdot_map_to_1e_6():
    rng = np.random.default_rng(3)
    points = np.stack(np.meshgrid([0.0, 1.5, 3.0], [0.0, 1.5, 3.0]), -1).reshape(-1, 2)
    net = NATEnet(input_dim=2, output_shape=(3, 3), lam=0.6, eta=1.0, T0=0.0, e_f=0.0, T_a=0.9)
    for _ in range(60):
        for x in points:
            dx = rng.standard_normal((4, 3))  # four observed moves at x
            net.learn(x, dx @ smooth_map(x).T, dx)
    assert net.n_nodes == len(points)
    for x in points:
        xdot = rng.standard_normal(3)
        np.testing.assert_allclose(net(x, xdot), smooth_map(x) @ xdot, atol=1e-6)


def test_constant_map_is_reproduced_everywhere():
    M = np.array([[2.0, 1.0], [0.0, -1.0]])
    net = NATEnet(input_dim=2, output_shape=(2, 2), e_f=0.0, T0=0.0)
    assert net.learn(np.zeros(2), np.eye(2) @ M.T, np.eye(2)).allocated  # M(0) = M from here on
    net.centres, net.widths = np.array([[0.0, 0.0], [1.0, 1.0]]), np.array([0.3, 0.5])
    net.outputs = np.stack([M, M])
    for x in ([0.5, -3.0], [40.0, 40.0]):  # every a_i underflows at (40, 40): still M
        np.testing.assert_allclose(net.predict(np.array(x)), M, atol=1e-12)


def test_save_load_is_exact(tmp_path):
    net = two_node_net()
    net.learn(QUIET, move_with_error(net, QUIET, DX, 0.5), DX)
    net.learn(BUSY, [0.3, 0.1], DX)
    path = net.save(tmp_path / "net.npz")
    loaded = NATEnet.load(path)
    for name in ("centres", "widths", "outputs"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(net, name))
    assert loaded.steps == net.steps and loaded.config() == net.config()
    x = np.array([0.4, -0.7])
    np.testing.assert_array_equal(loaded.predict(x), net.predict(x))


def test_load_rejects_other_files(tmp_path):
    with pytest.raises(CheckpointError, match="no such file"):
        NATEnet.load(tmp_path / "missing.npz")
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(CheckpointError, match="damaged"):
        NATEnet.load(tmp_path / "bad.npz")


@pytest.mark.parametrize(
    ("x", "dtheta", "dx"),
    [
        ([np.nan, 0.0], [0.1, 0.2], DX),
        (QUIET, [np.nan, 0.2], DX),
        (QUIET, [0.1, 0.2], [0.3, np.inf]),
        (QUIET, [0.1, 0.2], [0.0, 0.0]),
        (QUIET, [0.1, 0.2, 0.3], DX),
    ],
)
def test_bad_learning_input_raises_and_leaves_the_net_unchanged(x, dtheta, dx):
    net = two_node_net()
    before = (net.centres.copy(), net.widths.copy(), net.outputs.copy(), net.steps)
    with pytest.raises(ValueError):
        net.learn(np.array(x), np.array(dtheta), np.array(dx))
    np.testing.assert_array_equal(net.centres, before[0])
    np.testing.assert_array_equal(net.widths, before[1])
    np.testing.assert_array_equal(net.outputs, before[2])
    assert net.steps == before[3]


def test_nan_query_raises():
    with pytest.raises(ValueError, match="NaN"):
        two_node_net().predict(np.array([0.0, np.nan]))


def test_fixed_grid_places_centres_and_never_allocates():
    net = NATEnet.fixed_grid([0.0, -1.0], [2.0, 1.0], [3, 5], output_shape=(2, 2), lam=0.5)
    assert net.n_nodes == 15
    assert {tuple(c) for c in net.centres} == {
        (a, b) for a in (0.0, 1.0, 2.0) for b in (-1.0, -0.5, 0.0, 0.5, 1.0)
    }
    np.testing.assert_allclose(net.widths, 0.5 * 0.5)  # λ · smallest spacing (0.5)
    assert not net.learn(np.array([5.0, 5.0]), [1.0, 0.0], DX).allocated
    assert net.n_nodes == 15


def test_grid_counts_fit_the_budget():
    counts = grid_counts(np.zeros(3), np.array([4.0, 2.0, 1.0]), 24)
    # By hand (widest cell range/points first, first axis on ties, product ≤ 24): x, x, y, x,
    # x, y, x (cells 0.67, 0.67, 1 but a 2nd z point would make 42), x: (8, 3, 1).
    np.testing.assert_array_equal(counts, [8, 3, 1])
    assert np.prod(grid_counts(np.zeros(2), np.ones(2), 1)) == 1


def test_tracker_command_formula():
    M = np.diag([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    error, twist, dt = np.arange(6.0), np.ones(6), 0.1
    tracker = PathTracker(lambda theta: M, gain=0.5)
    np.testing.assert_allclose(
        tracker.command(np.zeros(6), error, twist, dt), M @ (0.5 * error + 0.5 * twist * dt)
    )
    with pytest.raises(ValueError, match="gain"):
        PathTracker(lambda theta: M, gain=1.5)
