"""What the figures show, read back from the matplotlib Figure: titles, axis labels, the number of
lines and points, and their data, all against the inputs given (hand-set data, not the plotting
code's own numbers)."""

from __future__ import annotations

import math
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest
from test_evaluation import _ScriptedEnv, _Still

from envs.cli.riacs_dataset import projections_figure
from envs.harness import plots
from envs.harness.evaluation import evaluate
from envs.studies.adaptation_media import FINE, adaptation_curves
from envs.studies.brause_figures import (
    PLOT_N,
    fit_figure,
    joints_figure,
    optimal_resolution_figure,
    path_error_figure,
    storage_error_figure,
)
from envs.studies.rl_comparison import THRESHOLDS, Curve
from envs.studies.rl_report import figure as rl_figure
from envs.studies.sweep_plots import error_vs_neurons_figure

#: The scripted trials of test_evaluation: distance (m) after each move, every trial counted where
#: it stopped (trial 1 stopped after the coarse move, trial 2 after fine 1).
DISTANCES = np.array(
    [[0.04, 0.01, 0.002], [0.03, 0.03, 0.03], [0.05, 0.004, 0.004], [0.06, 0.3, 0.2]]
)
MOVES_MADE = np.array([3, 1, 2, 3])


#: The subject line of the figures below (:func:`plots.subject`).
SUBJECT = plots.subject("puma560", "foveated", "servo", "VisuomotorSOM")


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def scripted():
    return evaluate(_ScriptedEnv(), _Still(), trials=4, fine_moves=2)


def _points(line) -> np.ndarray:
    return np.column_stack([line.get_xdata(), line.get_ydata()]).astype(float)


def test_learning_curve_has_a_line_per_move_and_a_point_per_evaluation():
    rows = [
        {"trial": 100, "mean_mm": [40.0, 9.0, 2.0]},
        {"trial": 200, "mean_mm": [30.0, 5.0, 1.0]},
        {"trial": 400, "mean_mm": [20.0, 3.0, 0.5]},
    ]
    fig = plots.learning_curve_figure(rows, reach=0.9, subject=SUBJECT)
    ax = fig.axes[0]
    lines = ax.get_lines()
    assert [line.get_label() for line in lines] == ["after coarse", "after fine 1", "after fine 2"]
    for k, line in enumerate(lines):
        np.testing.assert_array_equal(line.get_xdata(), [100, 200, 400])
        np.testing.assert_array_equal(line.get_ydata(), [r["mean_mm"][k] for r in rows])
    assert ax.get_yscale() == "log"
    assert ax.get_xlabel() == "training trials"
    assert ax.get_ylabel() == "mean error [mm]"
    assert ax.get_title() == f"Learning curve: held-out evaluations during training\n{SUBJECT}"
    assert fig.get_layout_engine() is not None  # constrained: no label over another


def test_subject_names_the_arm_the_settings_and_the_controller():
    assert SUBJECT == "PUMA 560 · sensing=foveated, control=servo · VisuomotorSOM"
    assert plots.subject("riacs", "project", "kinematic", "analytic").startswith("RIACS 3-DOF")


def test_error_histogram_counts_every_trial_after_every_move(scripted):
    ax = plots.error_histogram_figure(scripted, subject=SUBJECT).axes[0]
    assert len(ax.containers) == 3  # one histogram per move
    for bars in ax.containers:
        assert sum(bar.get_height() for bar in bars) == len(DISTANCES)
    stopped = int((MOVES_MADE < 3).sum())
    title = f"Errors on 4 held-out targets ({stopped} stopped early, counted)\n{SUBJECT}"
    assert ax.get_title() == title
    assert ax.get_xscale() == "log" and ax.get_xlabel() == "error [mm]"
    low, high = (
        ax.containers[0][0].get_x(),
        max(b.get_x() + b.get_width() for b in ax.containers[0]),
    )
    assert low == pytest.approx(DISTANCES.min() * 1e3) and high == pytest.approx(
        DISTANCES.max() * 1e3
    )


def test_error_histogram_has_no_figure_without_two_positive_errors(scripted):
    import dataclasses

    zero = dataclasses.replace(scripted, distances=np.zeros_like(scripted.distances))
    assert plots.error_histogram_figure(zero, subject=SUBJECT) is None


def test_error_vectors_draw_an_arrow_per_trial_from_target_to_end_point(scripted):
    fig = plots.error_vectors_figure(scripted, subject=SUBJECT)
    title = fig.get_suptitle()
    assert title.endswith(f"\n{SUBJECT}") and "(4 targets)" in title
    gain = float(re.search(r"arrows ×([0-9.e+]+)", title).group(1))
    # _ScriptedEnv: every target at the origin, the end point at (d, d, d) for the distance d
    # where the trial ended.
    ended = DISTANCES[np.arange(4), MOVES_MADE - 1]
    stopped = MOVES_MADE < 3
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert [ax.get_title() for ax in panels] == ["x-y", "x-z", "y-z"]
    for ax in panels:
        arrows = next(c for c in ax.collections if isinstance(c, matplotlib.quiver.Quiver))
        assert len(arrows.U) == len(DISTANCES)
        # Trial 3 (0.2 m, over 5x the median error) is cut at the axes, keeping its direction.
        bulk = np.arange(4) != 3
        np.testing.assert_allclose(arrows.U[bulk], gain * ended[bulk])
        np.testing.assert_allclose(arrows.V, arrows.U)
        assert 0 < arrows.U[3] < gain * ended[3]
        assert arrows.U[3] == pytest.approx(ax.get_xlim()[1])  # the target is at 0
        np.testing.assert_allclose(arrows.get_array(), ended * math.sqrt(3) * 1e3)
        crosses = next(c for c in ax.collections if c.get_label() == "stopped early")
        assert len(crosses.get_offsets()) == stopped.sum()
        assert crosses.get_sizes()[0] >= 80  # large enough to see
        assert ax.get_xlabel().endswith("[m]") and ax.get_ylabel().endswith("[m]")
    assert fig.axes[-1].get_ylabel() == "error after the last move [mm]"


@pytest.mark.parametrize(("gain", "rounded"), [(0.3, 1.0), (1.0, 1.0), (37.0, 20.0), (512, 500)])
def test_arrow_gain_is_rounded_down_to_one_two_or_five(gain, rounded):
    assert plots._round_gain(gain) == rounded


@pytest.mark.parametrize("move", [0, 1, 2])
def test_error_map_draws_every_trial_in_three_projections(scripted, move):
    fig = plots.error_map_figure(scripted, move=move, subject=SUBJECT)
    assert fig.get_suptitle().endswith(f"(4 targets)\n{SUBJECT}")
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert [ax.get_title() for ax in panels] == ["x-y", "x-z", "y-z"]
    made = MOVES_MADE > move
    for ax in panels:
        circles, crosses = ax.collections
        assert len(circles.get_offsets()) == made.sum()
        assert len(crosses.get_offsets()) == (~made).sum()
        assert crosses.get_sizes()[0] >= 80  # stopped trials: large crosses
        colours = np.concatenate([circles.get_array(), crosses.get_array()])
        expected = np.concatenate([DISTANCES[made, move], DISTANCES[~made, move]]) * 1e3
        np.testing.assert_allclose(colours, expected)
    colourbar = fig.axes[-1]
    assert colourbar.get_ylabel().startswith("error after ")


def test_lattice_in_image_draws_every_lattice_edge_through_the_chosen_camera():
    lattice = (3, 2, 2)
    w = np.arange(12 * 4, dtype=float).reshape(12, 4)  # neuron k: (4k, 4k+1, 4k+2, 4k+3)
    image = np.zeros((50, 60, 3))
    ax = plots.lattice_in_image_figure(w, lattice, image, camera=1, subject=SUBJECT).axes[0]
    assert ax.get_title() == f"Lattice 3x2x2 in camera right\n{SUBJECT}"
    neurons, *edges = ax.get_lines()
    # One layer (the middle, index 1 of the last axis) has edges: along axis 0 one line per
    # point of axis 1 (2 lines of 3 points), along axis 1 one per point of axis 0 (3 of 2).
    assert sorted(len(e.get_xdata()) for e in edges) == [2, 2, 2, 3, 3]
    layer = {tuple(p) for p in w.reshape(3, 2, 2, 4)[:, :, 1, 2:4].reshape(-1, 2)}
    assert {tuple(p) for e in edges for p in _points(e)} == layer
    np.testing.assert_array_equal(_points(neurons), w[:, 2:4])  # right camera: columns 2, 3
    assert ax.get_xlim() == (0, 60) and ax.get_ylim() == (50, 0)


def _sweep_rows() -> list[dict]:
    rows = []
    for robot, c in (("riacs", 30.0), ("puma", 90.0)):
        for n in (3, 4, 6):
            for seed in (0, 1):
                error = c * n**-2.0 * (1.0 + 0.2 * seed)
                rows.append({"robot": robot, "lattice": f"{n},{n},{n}", "seed": seed,
                             "trials": 40 * n**3, "n_per_axis": float(n),
                             "mean_mm": [error, error / 4]})  # fmt: skip
    return rows


def test_sweep_figure_has_a_panel_per_move_and_a_line_per_arm_with_the_slope():
    fig = error_vs_neurons_figure(_sweep_rows())
    panels = [ax for ax in fig.axes if ax.get_xlabel()]
    assert len(panels) == 2  # two moves
    for move, ax in enumerate(panels):
        assert ax.get_ylabel() == f"mean error after {('coarse', 'fine 1')[move]} move (mm)"
        lines = {line.get_label().split(":")[0]: line for line in ax.get_lines()}
        for robot, c in (("riacs", 30.0), ("puma", 90.0)):
            line = lines[f"robot={robot}"]
            # mean over the seeds' factors 1.0 and 1.2: 1.1 × C n^-2 (÷ 4 after fine 1)
            expected = 1.1 * c * np.array([3.0, 4.0, 6.0]) ** -2.0 / 4**move
            np.testing.assert_array_equal(line.get_xdata(), [3.0, 4.0, 6.0])
            np.testing.assert_allclose(line.get_ydata(), expected)
            assert line.get_label().endswith("b=-2.00")  # the power law's exponent
        seeds = [line for line in ax.get_lines() if line.get_label().startswith("_")]
        assert sorted(len(line.get_xdata()) for line in seeds) == [6, 6]  # 3 sizes × 2 seeds


def _adaptation_inputs():
    pre = [{"trial": t, "mean_mm": [9.0, 5.0, 40.0 / (1 + t)]} for t in (0, 100, 300)]
    learning = ("map, standard schedule", "map, continual mode")
    fixed = {"map frozen": 3.0, "AnalyticIK stale": 2.0, "JacobianIK stale": 1.5,
             "AnalyticIK recalibrated": 0.0}  # fmt: skip
    results = []
    for change in ("camera moved", "focal length"):
        curves = {n: [{"trial": t, "mean_mm": [9.0, 5.0, 3.0 / (1 + t)]} for t in (0, 50, 100, 200)]
                  for n in learning}  # fmt: skip
        after = {n: {"mean_mm": [1.0, 1.0, level]} for n, level in fixed.items()}
        before = {"map": {"mean_mm": [1.0, 1.0, 0.5]}}
        results.append({"change": change, "config": {"after_trials": 200}, "curves": curves,
                        "after": after, "before": before})  # fmt: skip
    return pre, results, fixed


def test_adaptation_curves_show_each_controller_after_each_change():
    pre, results, fixed = _adaptation_inputs()
    fig = adaptation_curves(pre, results, "a title")
    assert fig._suptitle.get_text() == "a title"
    assert len(fig.axes) == len(results)
    for ax, result in zip(fig.axes, results, strict=True):
        assert ax.get_title() == result["change"]
        lines = ax.get_lines()
        np.testing.assert_array_equal(
            _points(lines[0]), [[0, 40.0], [100, 40 / 101], [300, 40 / 301]]
        )
        by_label = {line.get_label(): line for line in lines[1:]}
        for name, curve in result["curves"].items():
            x = [300 + r["trial"] for r in curve]  # after the change at trial 300
            np.testing.assert_allclose(_points(by_label[name]), np.column_stack(
                [x, [r["mean_mm"][FINE] for r in curve]]))  # fmt: skip
        for name, level in fixed.items():
            np.testing.assert_array_equal(_points(by_label[name]), [[300, level], [500, level]])
        assert ax.get_xlim() == (100, 500)
    assert fig.axes[0].get_ylabel() == "held-out mean error after fine move 2 [mm]"


def test_rl_figure_has_a_line_per_method_at_the_mean_over_seeds():
    steps = [100, 1000, 10000]
    curves = [
        Curve("map", 0, steps, [0.020, 0.005, 0.001], [0.010, 0.002, 0.0005], 2.0),
        Curve("map", 1, steps, [0.040, 0.010, 0.003], [0.020, 0.004, 0.0015], 4.0),
        Curve("sac", 0, steps, [0.300, 0.200, 0.100], [0.250, 0.150, 0.090], 100.0),
    ]
    ax = rl_figure(curves, "a title").axes[0]
    assert ax.get_title() == "a title"
    assert ax.get_xlabel() == "environment steps (moves)"
    assert ax.get_ylabel() == "mean final distance [mm]"
    labelled = [line for line in ax.get_lines() if not line.get_label().startswith("_")]
    assert [line.get_label() for line in labelled] == ["visuomotor map (2 seeds)", "SAC (1 seed)"]
    np.testing.assert_allclose(_points(labelled[0]), np.column_stack([steps, [30.0, 7.5, 2.0]]))
    np.testing.assert_allclose(_points(labelled[1]), np.column_stack([steps, [300, 200, 100.0]]))
    levels = sorted(line.get_ydata()[0] for line in ax.get_lines() if line not in labelled)
    np.testing.assert_allclose(levels, sorted(t * 1e3 for t in THRESHOLDS))
    assert len(ax.collections) == 1  # the seed band: only the map has more than one seed


def _study(points: int = 7) -> dict:
    n = np.array([10.0, 20.0, 50.0, 100.0, 1000.0])
    s = np.linspace(0.0, 1.0, points)
    theta = np.column_stack([s, 2 * s, -s])  # rad
    error = np.outer(n**-2.0, 1.0 + s)  # (n, points)
    fits = {"joint [rad]": {"b": -2.0, "C": 1.0}}
    return {"s": s, "n": n, "P": 3, "theta": theta, "joint_max": error, "cart": 0.5 * error,
            "fits": fits}  # fmt: skip


def test_brause_joint_figure_has_the_three_joints_in_degrees():
    study = _study()
    ax = joints_figure(study).axes[0]
    assert [line.get_label() for line in ax.get_lines()] == ["θ1", "θ2", "θ3"]
    for i, line in enumerate(ax.get_lines()):
        np.testing.assert_allclose(line.get_ydata(), study["theta"][:, i] * 180 / math.pi)
    assert ax.get_title().startswith("Fig. 5f")


@pytest.mark.parametrize(("key", "scale", "unit"), [("joint_max", 1.0, "rad"), ("cart", 1e3, "mm")])
def test_brause_path_error_figure_has_a_line_per_plotted_n_and_the_point_p(key, scale, unit):
    study = _study()
    ax = path_error_figure(study, key, unit, scale, "Fig. 5x").axes[0]
    *lines, p = ax.get_lines()
    assert [line.get_label() for line in lines] == [f"n = {n}" for n in PLOT_N]
    for line, n in zip(lines, PLOT_N, strict=True):
        row = list(study["n"]).index(n)
        np.testing.assert_allclose(line.get_ydata(), study[key][row] * scale)
    assert p.get_label() == "P" and p.get_xdata()[0] == study["s"][3]
    assert ax.get_ylabel() == f"error ({unit})" and ax.get_title() == "Fig. 5x"


def test_brause_fit_figure_draws_the_error_at_p_and_the_learned_maps():
    study = _study()
    som = [{"protocol": p, "n_equivalent": n, "joint_max_path": 1 / n, "joint_median_path": 0.5 / n}
           for p in ("brause", "mrs") for n in (3.0, 4.0)]  # fmt: skip
    ax, right = fit_figure(study, som).axes
    at_p = ax.get_lines()[0]
    np.testing.assert_allclose(
        _points(at_p), np.column_stack([study["n"], study["n"] ** -2.0 * 1.5])
    )
    learned = [line for line in ax.get_lines() if line.get_label().startswith("learned SOM")]
    assert len(learned) == 4 and all(len(line.get_xdata()) == 2 for line in learned)
    # r_n = ld(V_θ / e) − 1 (5.9): one bit more per halving of the error.
    bits = right.get_lines()[0].get_ydata()
    np.testing.assert_allclose(np.diff(bits), -np.diff(np.log2(study["n"] ** -2.0)))


def _resolution() -> dict:
    mb = np.array([0.1, 1.0, 10.0])
    curve = [{"storage_MB": m, "e_max_rad": 1e-3 / m, "e_max_equal_rad": 2e-3 / m,
              "cartesian_mm": 0.1 / m, "cartesian_equal_mm": 0.2 / m, "r_w": 10 + m,
              "r_theta": 11 + m, "r_A": 5 + m, "n": 20 * m} for m in mb]  # fmt: skip
    models = ("one model", "another", "a third")  # the study draws three error models
    return {**{name: {"curve": curve} for name in models}, "published": {}}


def test_brause_resolution_figures_draw_each_error_model_against_storage():
    res = _resolution()
    bytes_ = [c["storage_MB"] * 1e6 for c in res["one model"]["curve"]]
    left, right = storage_error_figure(res).axes
    labels = [line.get_label() for line in left.get_lines()]
    assert labels == [f"{kind}, {name}" for name in ("one model", "another", "a third")
                      for kind in ("optimal", "equal r")]  # fmt: skip
    np.testing.assert_allclose(left.get_lines()[1].get_xdata(), bytes_)
    np.testing.assert_allclose(left.get_lines()[1].get_ydata(), [0.02, 0.002, 0.0002])
    assert len(right.get_lines()) == 7  # 6 curves and the published point
    ax, ax2 = optimal_resolution_figure(res).axes
    assert len(ax.get_lines()) == 3 * 3 + 1 and len(ax2.get_lines()) == 3 + 1
    np.testing.assert_allclose(ax2.get_lines()[0].get_ydata(), [2.0, 20.0, 200.0])


def test_riacs_projections_show_every_row_in_each_projection():
    data = np.random.default_rng(0).uniform(-1, 1, (25, 10))
    fig = projections_figure(data)
    view, *planes = fig.axes
    np.testing.assert_array_equal(np.column_stack(view.collections[0]._offsets3d), data[:, :3])
    assert view.get_title() == "Axis projection of original data set"
    for ax, (i, j, name) in zip(planes, ((0, 1, "XY"), (0, 2, "XZ"), (1, 2, "YZ")), strict=True):
        np.testing.assert_array_equal(ax.collections[0].get_offsets(), data[:, [i, j]])
        assert ax.get_title() == f"{name} axis projection"
        assert (ax.get_xlabel(), ax.get_ylabel()) == (name[0].lower(), name[1].lower())
