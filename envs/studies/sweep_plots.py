"""Figures of a sweep: held-out error after each move against the lattice size, log-log, one line
per group of cells that differ only in lattice and seed (arm, rule, protocol, ...), each with
its fitted slope, and for reference Brause's e^LA(n) = C·n^b (5.8) and his optimal resolution
(§6.2: n = 39.6 neurons per axis, Cartesian e^MAX = 0.201 mm with equal resolutions, 0.164 mm
with the optimal ones, for 1.9 MB), both for the PUMA's reach map. A sweep with grasp cells
(PumaGrasp-v0, whose neurons N are the hierarchical map's leaves) adds a second row of panels:
the hand's orientation error after each move against the leaves."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from typing import Any

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from envs.harness.plots import MOVE_NAMES, save_figure
from models.analyses.brause_linear_error import PAPER_B, PAPER_C, fit_power_law
from models.analyses.brause_optimal_resolution import PUBLISHED

#: Columns that do not separate groups: the x axis, the seeds, and per-cell results.
_NOT_GROUPING = {
    "cell", "lattice", "seed", "neurons", "n_per_axis", "learned_trials", "eval_trials",
    "complete_fraction", "mean_mm", "median_mm", "p90_mm", "mean_percent_reach",
    "seconds_last_attempt", "env", "orientation_lattice", "mean_deg", "median_deg", "p90_deg",
}  # fmt: skip


def groups(rows: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    """Rows grouped by every setting except lattice and seed; the label names the settings
    that differ between groups."""
    keys = sorted({k for row in rows for k in row} - _NOT_GROUPING)
    shapes = [(str(row.get("lattice")), str(row.get("orientation_lattice"))) for row in rows]
    pairs = {(shape, row.get("trials")) for shape, row in zip(shapes, rows, strict=True)}
    if len(pairs) == len({p[0] for p in pairs}):  # trials follow the lattices (trials_per_neuron)
        keys.remove("trials")
    varying = [k for k in keys if len({str(row.get(k)) for row in rows}) > 1] or ["robot"]
    out: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for row in rows:
        out[", ".join(f"{k}={row.get(k)}" for k in varying)].append(row)
    return dict(out)


def fit_by_group(
    rows: list[dict[str, Any]], move: int, column: str = "mean_mm", x: str = "n_per_axis"
) -> dict[str, dict[str, Any]]:
    """Per group: the sizes ``x`` (n per axis, or ``neurons``), the mean over seeds of the error
    ``column`` after ``move`` (mm, or ``mean_deg``), and the power-law fit error = C·x^b over x
    (where at least two sizes exist)."""
    fits = {}
    for label, members in groups(rows).items():
        by_n: dict[float, list[float]] = defaultdict(list)
        for row in members:
            if len(row[column]) > move:
                by_n[row[x]].append(row[column][move])
        n = np.array(sorted(by_n))
        e = np.array([np.mean(by_n[k]) for k in n])
        b, C = fit_power_law(n, e) if len(n) > 1 and np.all(e > 0) else (float("nan"),) * 2
        fits[label] = {"x": n.tolist(), "mean": e.tolist(), "slope": b, "C": C}
    return fits


def error_vs_neurons(rows: list[dict[str, Any]], path: Path) -> Path:
    """Write :func:`error_vs_neurons_figure` to ``path``."""
    return save_figure(error_vs_neurons_figure(rows), path, dpi=110, bbox_inches=None)


def error_vs_neurons_figure(rows: list[dict[str, Any]]) -> Figure:
    """One panel per move: mean error (mm, all held-out trials, mean over seeds) against
    neurons per axis n = N^(1/3), log-log, with fitted slopes, Brause's e^LA(n) (rad, at his
    point P; right axis) for the slope, and his optimal resolution (n, e^MAX in mm); Brause's
    lines only where reach cells are drawn. With grasp cells a second row: their mean orientation
    error (degrees) after each move against the leaves N."""
    moves = max(len(row["mean_mm"]) for row in rows)
    pose = [row for row in rows if "mean_deg" in row]
    panels = 2 if pose else 1
    fig, axes = plt.subplots(panels, moves, figsize=(4.6 * moves, 4.2 * panels), squeeze=False)
    for move, ax in enumerate(axes[0]):
        _position_panel(ax, rows, move, brause=len(pose) < len(rows))
        if pose:
            ax.set_xlabel("neurons per axis n = N^(1/3) (grasp cells: N = leaves)")
    for move, ax in enumerate(axes[1] if pose else []):
        _orientation_panel(ax, pose, move)
    fig.tight_layout()
    return fig


def _position_panel(ax, rows: list[dict[str, Any]], move: int, brause: bool) -> None:
    """Mean position error after ``move`` against n per axis, and Brause's lines if asked."""
    for label, fit in fit_by_group(rows, move).items():
        line = ax.loglog(fit["x"], fit["mean"], "o-", ms=4, label=f"{label}: b={fit['slope']:.2f}")
        seeds = [(r["n_per_axis"], r["mean_mm"][move]) for r in groups(rows)[label]]
        ax.loglog(*zip(*seeds, strict=True), ".", color=line[0].get_color(), alpha=0.4)
    twins = []
    if brause:
        optimum = PUBLISHED["n"], (PUBLISHED["e_equal_mm"], PUBLISHED["e_opt_mm"])
        ax.loglog([optimum[0]] * 2, optimum[1], "k*", ms=7,
                  label=f"Brause §6.2 optimum: n = {optimum[0]},\ne^MAX = {optimum[1][0]} / "
                  f"{optimum[1][1]} mm (equal / optimal bits)")  # fmt: skip
        n = np.geomspace(min(r["n_per_axis"] for r in rows), max(r["n_per_axis"] for r in rows))
        twin = ax.twinx()  # rad, as many decades per inch as the mm axis: slopes compare
        line = PAPER_C * n**PAPER_B
        twin.loglog(n, line, "k--", lw=1, label=f"Brause e^LA = {PAPER_C}·n^{PAPER_B}")
        low, high = ax.get_ylim()
        shift = np.sqrt(line[0] * line[-1] / (low * high))
        twin.set_ylim(low * shift, high * shift)
        twin.set_ylabel("Brause e^LA (rad)", fontsize=8)
        twins.append(twin)
    ticks = sorted({round(r["n_per_axis"], 2) for r in rows})
    ax.set_xticks(ticks, [f"{t:g}" for t in ticks], fontsize=7)
    ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())  # n only where measured
    ax.set_xlabel("neurons per axis n = N^(1/3)")
    ax.set_ylabel(f"mean error after {MOVE_NAMES[move]} move (mm)")
    handles = [h for a in (ax, *twins) for h in a.get_legend_handles_labels()[0]]
    ax.legend(handles=handles, loc="lower left", fontsize=6)
    ax.grid(True, which="both", alpha=0.3)


def _orientation_panel(ax, rows: list[dict[str, Any]], move: int) -> None:
    """Mean orientation error (degrees) of the grasp cells ``rows`` after ``move`` against their
    leaves N, log-log, one line per group with its fitted slope."""
    for label, fit in fit_by_group(rows, move, "mean_deg", "neurons").items():
        line = ax.loglog(fit["x"], fit["mean"], "o-", ms=4, label=f"{label}: b={fit['slope']:.2f}")
        seeds = [(r["neurons"], r["mean_deg"][move]) for r in groups(rows)[label]]
        ax.loglog(*zip(*seeds, strict=True), ".", color=line[0].get_color(), alpha=0.4)
    ticks = sorted({r["neurons"] for r in rows})
    ax.set_xticks(ticks, [f"{t:g}" for t in ticks], fontsize=7)
    ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())  # N only where measured
    ax.set_xlabel("leaves N = position × orientation nodes")
    ax.set_ylabel(f"mean orientation error after {MOVE_NAMES[move]} move (deg)")
    ax.legend(loc="lower left", fontsize=6)
    ax.grid(True, which="both", alpha=0.3)
