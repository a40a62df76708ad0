"""Figures that a few far-off trials cannot wreck: the error vectors' axes are set by the bulk of
the trials, far arrows are cut at the axes and counted; the lattice plot draws one layer."""

from __future__ import annotations

import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest

from envs.harness import plots
from envs.harness.evaluation import Evaluation

SUBJECT = plots.subject("riacs", "foveated", "servo", "VisuomotorSOM")
FAR = np.array([3.8, 0.0, 0.0])  # m: a stopped trial's error, as in the RIACS evaluation


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _evaluation(far: bool) -> Evaluation:
    """60 targets in the unit cube, errors of about 1 mm in random directions; with ``far``,
    the last trial ends ``FAR`` from its target."""
    rng = np.random.default_rng(5)
    targets = rng.uniform(0.0, 1.0, (60, 3))
    errors = rng.normal(0.0, 1e-3, (60, 3))
    if far:
        errors[-1] = FAR
    distances = np.linalg.norm(errors, axis=1)[:, None]
    return Evaluation(
        distances=distances,
        pixel_errors=np.zeros_like(distances),
        target_pos=targets,
        reached=targets + errors,
        reach=1.0,
        seconds_per_query=0.0,
    )


def _panels(fig):
    return [ax for ax in fig.axes if ax.get_title() in ("x-y", "x-z", "y-z")]


def _gain(fig) -> float:
    return float(re.search(r"arrows ×([0-9.e+]+)", fig.get_suptitle()).group(1))


def test_one_far_trial_does_not_set_the_axes():
    clean = plots.error_vectors_figure(_evaluation(far=False), subject=SUBJECT)
    wrecked = plots.error_vectors_figure(_evaluation(far=True), subject=SUBJECT)
    gain = _gain(wrecked)
    assert gain == _gain(clean)  # the median error sets the gain
    for a, b in zip(_panels(clean), _panels(wrecked), strict=True):
        # The targets span [0, 1]; the far arrow's tip lies gain × 3.8 m out, far beyond.
        assert b.get_xlim()[1] < 1.3 < 1 + gain * FAR[0]
        np.testing.assert_allclose(b.get_xlim(), a.get_xlim(), atol=0.02)
        np.testing.assert_allclose(b.get_ylim(), a.get_ylim(), atol=0.02)


def test_the_far_arrow_is_cut_at_the_axes_marked_and_counted():
    result = _evaluation(far=True)
    fig = plots.error_vectors_figure(result, subject=SUBJECT)
    gain = _gain(fig)
    for ax, (i, j) in zip(_panels(fig), ((0, 1), (0, 2), (1, 2)), strict=True):
        arrows = next(c for c in ax.collections if isinstance(c, matplotlib.quiver.Quiver))
        error = result.reached - result.target_pos
        bulk = slice(0, -1)
        np.testing.assert_allclose(arrows.U[bulk], gain * error[bulk, i])
        np.testing.assert_allclose(arrows.V[bulk], gain * error[bulk, j])
        marks = [c for c in ax.collections if c.get_label().startswith("arrow cut")]
        if i != 0:  # the far error lies along x: nothing to cut in the y-z projection
            assert len(marks[0].get_offsets()) == 0
            np.testing.assert_allclose(arrows.U[-1], gain * error[-1, i])
            continue
        assert marks[0].get_label().startswith("arrow cut at the axes (1: ")
        (end,) = marks[0].get_offsets()
        start = result.target_pos[-1, [i, j]]
        # The cut arrow keeps its direction (along +x) and ends on the right edge of the axes.
        assert arrows.U[-1] == pytest.approx(ax.get_xlim()[1] - start[0])
        assert arrows.V[-1] == pytest.approx(0.0, abs=1e-12)
        np.testing.assert_allclose(end, start + np.array([arrows.U[-1], arrows.V[-1]]))
        assert any("arrow cut" in t.get_text() for t in ax.get_legend().get_texts())


def test_without_far_trials_nothing_is_cut():
    result = _evaluation(far=False)
    fig = plots.error_vectors_figure(result, subject=SUBJECT)
    gain = _gain(fig)
    error = result.reached - result.target_pos
    for ax, (i, j) in zip(_panels(fig), ((0, 1), (0, 2), (1, 2)), strict=True):
        arrows = next(c for c in ax.collections if isinstance(c, matplotlib.quiver.Quiver))
        np.testing.assert_allclose(arrows.U, gain * error[:, i])
        np.testing.assert_allclose(arrows.V, gain * error[:, j])
        marks = [c for c in ax.collections if c.get_label().startswith("arrow cut")]
        assert len(marks[0].get_offsets()) == 0
        assert ax.get_legend() is None  # nothing stopped, nothing cut: no legend


def test_the_lattice_plot_draws_one_layer_and_refuses_a_layer_outside_the_lattice():
    lattice = (4, 3, 5)
    w = np.random.default_rng(2).uniform(0, 100, (60, 4))
    image = np.zeros((120, 160, 3))
    ax = plots.lattice_in_image_figure(w, lattice, image, layer=4, subject=SUBJECT).axes[0]
    neurons, *edges = ax.get_lines()
    assert len(neurons.get_xdata()) == 60  # every neuron a dot
    # Layer 4 (the last) of the last axis: 3 lines of 4 points and 4 lines of 3 points.
    assert sorted(len(e.get_xdata()) for e in edges) == [3] * 4 + [4] * 3
    layer = w.reshape(4, 3, 5, 4)[:, :, 4, :2].reshape(-1, 2)
    drawn = np.concatenate([np.column_stack([e.get_xdata(), e.get_ydata()]) for e in edges])
    assert {tuple(p) for p in drawn} == {tuple(p) for p in layer}
    with pytest.raises(ValueError, match=r"layer 5 is not in 0\.\.4 of lattice 4x3x5"):
        plots.lattice_in_image_figure(w, lattice, image, layer=5, subject=SUBJECT)


def test_a_two_axis_lattice_draws_every_edge():
    w = np.arange(6 * 4, dtype=float).reshape(6, 4)
    ax = plots.lattice_in_image_figure(w, (3, 2), np.zeros((40, 40, 3)), subject=SUBJECT).axes[0]
    _, *edges = ax.get_lines()
    assert sorted(len(e.get_xdata()) for e in edges) == [2, 2, 2, 3, 3]
