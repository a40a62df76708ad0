"""Brause (1989) §5-6: table 6a against the printed numbers, the linear-approximation error against
an independent computation and the Taylor order, the fit and resolution formulas."""

import json

import numpy as np
import pytest

from envs.cli import reproduce_brause
from models.analyses import brause_linear_error as B
from models.puma560 import wrist_center, wrist_ik
from models.puma560.kinematics import jacobian

from helpers import assert_drawn_png

#: Table 6a as printed (n: SE, "3SE = 4 byte", "2SE = 4 byte"), typed from the report.
PRINTED = {
    10: (1.5e4, 20e3, 30e3),
    50: (1.87e6, 2.5e6, 3.74e6),
    100: (1.5e7, 20e6, 30e6),
    1000: (1.5e10, 20e9, 30e9),
}


def test_table_6a_equals_the_printed_values():
    n = np.array(sorted(PRINTED))
    table = B.storage(n, B.SE_PER_NEURON_BRAUSE)
    np.testing.assert_array_equal(table["neurons"], [1e3, 1.25e5, 1e6, 1e9])
    printed = np.array([PRINTED[k] for k in n])
    # The report truncates to 3 digits (1.875e6 -> 1.87e6, 3.75 MB -> 3.74 MB).
    for column, key in enumerate(("elements", "bytes_10bit", "bytes_12bit")):
        np.testing.assert_allclose(table[key], printed[:, column], rtol=3e-3)


def test_camera_map_stores_19_numbers_per_neuron():
    # w: (u1, v1, u2, v2); Θ: 3 joints; A: 3 × 4.
    assert B.camera_map_numbers_per_neuron(joints=3) == 4 + 3 + 12
    assert B.storage(np.array([10]), 19)["elements"][0] == 19_000


def test_central_difference_is_the_inverse_jacobian():
    _, w = B.path(B.PATH_START, B.PATH_END, 9)
    A = B.central_difference(w)
    theta = wrist_ik(w, 1, 1)[0]
    J = jacobian(np.concatenate([theta, np.zeros_like(theta)], axis=1), point=4)[:, :3, :3]
    np.testing.assert_allclose(A, np.linalg.inv(J), rtol=1e-6, atol=1e-6)


def test_border_errors_match_a_direct_computation():
    w = np.array([[0.05, 0.55, 0.1]])
    cell = 0.717 / 20
    joint, cart = B.border_errors(w, cell)
    theta_c = wrist_ik(w[0], 1, 1)[0]
    h = 1e-6
    A = np.column_stack(
        [
            (wrist_ik(w[0] + h * e, 1, 1)[0] - wrist_ik(w[0] - h * e, 1, 1)[0]) / (2 * h)
            for e in np.eye(3)
        ]
    )
    worst_joint, worst_cart = np.zeros(3), 0.0
    for sx in (-1, 0, 1):
        for sy in (-1, 0, 1):
            for sz in (-1, 0, 1):
                offset = 0.5 * cell * np.array([sx, sy, sz])
                if np.count_nonzero(offset) not in (1, 3):  # corners and face centres
                    continue
                x = w[0] + offset
                approx = theta_c + A @ offset
                worst_joint = np.maximum(worst_joint, np.abs(wrist_ik(x, 1, 1)[0] - approx))
                worst_cart = max(worst_cart, np.linalg.norm(x - wrist_center(approx)))
    np.testing.assert_allclose(joint[0], worst_joint, rtol=1e-5)
    assert cart[0] == pytest.approx(worst_cart, rel=1e-5)


def test_linear_approximation_error_falls_as_n_to_the_minus_two():
    # Taylor: the error of a tangent-plane approximation is ½ hᵀ H h with h = Δx/2 ∝ 1/n.
    w = np.array([[0.0, 0.55, 0.0]])
    n = np.array([100, 1000])
    e = [B.border_errors(w, 0.717 / k)[0].max() for k in n]
    assert e[0] / e[1] == pytest.approx(100, rel=0.02)


def test_slope_scan_fits_the_same_slope_as_the_path_study():
    points, b, C = B.slope_scan(spacing=0.2)
    n = np.array(B.SCAN_N, dtype=float)
    i = len(points) // 2
    e = [B.border_errors(points[i : i + 1], B.BRAUSE_EDGE / k)[0].max() for k in n]
    slope, intercept = np.polyfit(np.log10(n), np.log10(e), 1)
    assert b[i] == pytest.approx(slope, rel=1e-9) and C[i] == pytest.approx(10**intercept)
    assert np.all(B.exact_joints(points)[1])


def test_unreachable_cells_have_no_error():
    far = np.array([[0.0, 0.86, 0.0]])  # wrist centre at the edge of reach
    joint, cart = B.border_errors(far, 0.2)
    assert np.isnan(joint).all() and np.isnan(cart).all()


def test_fit_and_resolution_formulas():
    n = np.array([5.0, 10, 100, 1000])
    b, C = B.fit_power_law(n, 2.0 * n**-2.5)
    assert b == pytest.approx(-2.5) and C == pytest.approx(2.0)
    assert B.resolution_bits(2 * np.pi / 2**11) == pytest.approx(10.0)  # (5.9)
    e = np.array([3.0, 2.0, 2.5, 1.0, 4.0, 5.0, 0.5, 0.1])
    assert B.first_local_maximum(e) == 2
    assert B.first_local_maximum(np.arange(10.0)) == 4  # no peak: largest of the first half


def test_training_loop_senses_the_wrist_centre():
    class Recorder:
        def __init__(self):
            self.trials = []

        def reset(self):
            pass

        def act(self, u, v=None):
            return np.array([0.1, -1.0, 0.2]) if v is None else np.array([0.2, -0.9, 0.1])

        def learn(self, u, theta0, v0, theta1, v1):
            self.trials.append((u, theta0, v0, theta1, v1))
            return True

    learner = Recorder()
    assert B.train_cartesian(learner, 5, np.random.default_rng(0)) == 5
    for u, theta0, v0, theta1, v1 in learner.trials:
        assert np.all((u >= B.PATH_START) & (u <= B.PATH_END))
        np.testing.assert_allclose(v0, wrist_center(theta0))
        np.testing.assert_allclose(v1, wrist_center(theta1))


def test_script_writes_the_table_and_a_fit_near_minus_two(tmp_path):
    reproduce_brause.main(
        ["--out", str(tmp_path), "--no-som", "--points", "81", "--scan-spacing", "0.15"]
    )
    result = json.loads((tmp_path / "brause.json").read_text())
    for row in result["table_6a"]:
        assert row["elements"] == pytest.approx(PRINTED[row["n"]][0], rel=3e-3)
    assert result["fits"]["joint [rad]"]["b"] == pytest.approx(-2.0, abs=0.05)
    scan = result["slope_scan"]
    assert scan["points"] > 100 and -2.3 < scan["b_min"] <= scan["b_max"] < -1.9
    published = result["appendix_B"]["paper (b, C), g as published"]["at_r_w_17"]
    assert round(published["n"], 1) == 39.6 and round(published["r_equal"], 1) == 16.4
    figures = ("fig5f_joints", "fig5g_joint_error", "fig5h_cartesian_error", "fig5i_fit")
    for name in (*figures, "fig6_2_storage_error", "figB_1_optimal_resolution"):
        assert_drawn_png(tmp_path / f"{name}.png")
