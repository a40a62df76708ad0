"""Evaluation figures (matplotlib, headless): learning curve, error histogram, the lattice in a
camera image, error vectors and an error map across the workspace.

Each figure is built by a ``*_figure`` function that returns the matplotlib Figure (tests read
its titles, labels and lines), and written by the function of the plain name through
:func:`save_figure`. Every title ends with a *subject* line (:func:`subject`: the arm, the
sensing and control settings and the controller), so that a figure read on its own says what
it shows; figures use matplotlib's constrained layout, so that no label covers another.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from envs.harness.evaluation import Evaluation
from envs.robots import ROBOTS
from learners.persistence import write_atomic

MOVE_NAMES = ("coarse", "fine 1", "fine 2", "fine 3", "fine 4")
#: Trials that stopped early (a marker not seen): large black crosses over the coloured points.
STOPPED_STYLE = {"marker": "X", "s": 90, "c": "black", "edgecolors": "white", "linewidths": 0.8}
#: The same in the error map, where the cross keeps its error colour inside a black outline.
STOPPED_MAP_STYLE = {"marker": "X", "s": 110, "edgecolors": "black", "linewidths": 1.2}
#: The three projections of the workspace: (horizontal axis, vertical axis, name).
PROJECTIONS = ((0, 1, "x-y"), (0, 2, "x-z"), (1, 2, "y-z"))


def subject(robot: str, sensing: str, control: str, controller: str) -> str:
    """The line that names what a figure shows, e.g. ``PUMA 560 · sensing=foveated,
    control=servo · VisuomotorSOM``: the arm by its :attr:`~envs.robots.RobotSpec.title` (a
    name outside :data:`~envs.robots.ROBOTS` as it is)."""
    arm = ROBOTS[robot].title if robot in ROBOTS else robot
    return f"{arm} · sensing={sensing}, control={control} · {controller}"


def _move_name(k: int) -> str:
    return MOVE_NAMES[k] if k < len(MOVE_NAMES) else f"fine {k}"


def learning_curve(rows: list[dict], reach: float, path: Path, *, subject: str) -> Path:
    """Write :func:`learning_curve_figure` to ``path``."""
    return save_figure(learning_curve_figure(rows, reach, subject=subject), path)


def learning_curve_figure(rows: list[dict], reach: float, *, subject: str) -> Figure:
    """Held-out mean error (all trials) after each move vs training trials, log scale (mm and
    % reach): one line per move, one point per evaluation row.

    Args:
        rows: evaluation rows with ``trial`` and ``mean_mm`` (one error per move, mm).
        reach: the arm's reach (m), for the right axis in % of reach.
        subject: arm, settings and controller of the evaluations during training (the training
            run's own settings, e.g. the idealised sensing="project", control="kinematic").
    """
    trials = np.array([r["trial"] for r in rows])
    errors = np.array([r["mean_mm"] for r in rows])  # (evals, moves)
    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    for k in range(errors.shape[1]):
        ax.semilogy(trials, errors[:, k], marker="o", ms=3, label=f"after {_move_name(k)}")
    ax.set_xlabel("training trials")
    ax.set_ylabel("mean distance to target [mm]")
    secondary = ax.secondary_yaxis(
        "right", functions=(lambda mm: mm / (reach * 1e3) * 100, lambda p: p * reach * 1e3 / 100)
    )
    secondary.set_ylabel("% of reach")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    ax.set_title(f"Learning curve: held-out evaluations during training\n{subject}", fontsize=10)
    return fig


def error_histogram(result: Evaluation, path: Path, *, subject: str) -> Path | None:
    """Write :func:`error_histogram_figure` to ``path``; None (nothing written) when it has no
    figure."""
    fig = error_histogram_figure(result, subject=subject)
    return None if fig is None else save_figure(fig, path)


def error_histogram_figure(result: Evaluation, *, subject: str) -> Figure | None:
    """Distribution of the distance to the target after each move over all trials (a trial that
    stopped counts where it stopped; log-spaced bins, mm); None when fewer than two errors are
    above 0 (no log-spaced bins)."""
    mm = result.distances * 1e3
    positive = mm[mm > 0]
    if positive.size < 2:
        return None
    floor = positive.min()  # exact zeros go into the lowest bin of the log axis
    bins = np.logspace(np.log10(floor), np.log10(positive.max()), 40)
    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    for k in range(result.moves):
        ax.hist(np.maximum(mm[:, k], floor), bins=bins, alpha=0.55, label=_move_name(k))
    ax.set_xscale("log")
    ax.set_xlabel("distance to target [mm]")
    ax.set_ylabel("trials")
    ax.legend()
    stopped = int((~result.complete).sum())
    ax.set_title(
        f"Errors on {len(mm)} held-out targets ({stopped} stopped early, counted)\n{subject}",
        fontsize=10,
    )
    return fig


def lattice_in_image(
    w: np.ndarray,
    lattice: tuple[int, ...],
    image: np.ndarray,
    path: Path,
    camera: int = 0,
    *,
    subject: str,
) -> Path:
    """Write :func:`lattice_in_image_figure` to ``path``."""
    return save_figure(lattice_in_image_figure(w, lattice, image, camera, subject=subject), path)


def lattice_in_image_figure(
    w: np.ndarray, lattice: tuple[int, ...], image: np.ndarray, camera: int = 0, *, subject: str
) -> Figure:
    """The neurons' w_r in one camera's image with lattice edges, as in Kohonen's Fig. 3b.

    Args:
        w: the neurons' camera coordinates (neurons, 4) pixels, C order over ``lattice``.
        lattice: the lattice shape.
        image: the camera image (height, width, 3) drawn beneath.
        camera: 0 left (columns 0, 1 of ``w``), 1 right (columns 2, 3).
    """
    grid = w.reshape(*lattice, -1)[..., 2 * camera : 2 * camera + 2]  # (*lattice, 2) pixels
    fig, ax = plt.subplots(figsize=(6.4, 5.2), layout="constrained")
    ax.imshow(image, alpha=0.55)
    for axis in range(len(lattice)):
        lines = np.moveaxis(grid, axis, -2).reshape(-1, lattice[axis], 2)
        for line in lines:
            ax.plot(line[:, 0], line[:, 1], "-", color="tab:blue", lw=0.6, alpha=0.8)
    flat = grid.reshape(-1, 2)
    ax.plot(flat[:, 0], flat[:, 1], ".", color="navy", ms=2.5)
    ax.set_xlim(0, image.shape[1])
    ax.set_ylim(image.shape[0], 0)
    ax.set_xlabel("u [px]")
    ax.set_ylabel("v [px]")
    side = "left" if camera == 0 else "right"
    ax.set_title(f"Lattice {'x'.join(map(str, lattice))} in camera {side}\n{subject}", fontsize=10)
    return fig


def error_vectors(result: Evaluation, path: Path, *, subject: str) -> Path:
    """Write :func:`error_vectors_figure` to ``path``."""
    return save_figure(error_vectors_figure(result, subject=subject), path)


def error_vectors_figure(result: Evaluation, *, subject: str) -> Figure:
    """Where the arm ended relative to each target, three projections: an arrow from the target
    to the end point (after the last move, or where the trial stopped), magnified by one factor
    for all (stated in the title) so that millimetre errors show on a workspace of decimetres,
    coloured by the error (mm, log scale); trials that stopped early are marked by crosses.
    """
    t, reached = result.target_pos, result.reached  # (n, 3) m each
    error = reached - t  # (n, 3) m
    mm = np.maximum(np.linalg.norm(error, axis=1) * 1e3, 1e-3)  # log colour scale: 1 µm floor
    span = float(np.ptp(t, axis=0).max()) or 1.0  # m
    typical = float(np.median(np.linalg.norm(error, axis=1)))  # m
    gain = _round_gain(0.06 * span / typical) if typical > 0 else 1.0
    stopped = ~result.complete
    norm = matplotlib.colors.LogNorm(vmin=mm.min(), vmax=max(mm.max(), mm.min() * 1.01))
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6), layout="constrained")
    for ax, (i, j, name) in zip(axes, PROJECTIONS, strict=True):
        arrows = ax.quiver(
            t[:, i], t[:, j], gain * error[:, i], gain * error[:, j], mm,
            cmap="viridis", norm=norm, angles="xy", scale_units="xy", scale=1, width=0.004,
        )  # fmt: skip
        tips = t[:, [i, j]] + gain * error[:, [i, j]]  # (n, 2) m: the axes show whole arrows
        ax.update_datalim(tips)
        ax.scatter(t[stopped, i], t[stopped, j], label="stopped early", **STOPPED_STYLE)
        ax.set_xlabel("xyz"[i] + " [m]")
        ax.set_ylabel("xyz"[j] + " [m]")
        ax.set_title(name)
        ax.set_aspect("equal", adjustable="datalim")
    if stopped.any():
        axes[0].legend(loc="best")
    fig.colorbar(arrows, ax=axes, label="error after the last move [mm]")
    fig.suptitle(f"Target → end point, arrows ×{gain:g} ({len(t)} targets)\n{subject}", fontsize=11)
    return fig


def _round_gain(gain: float) -> float:
    """``gain`` rounded down to 1, 2 or 5 times a power of ten (at least 1)."""
    if gain <= 1:
        return 1.0
    power = 10 ** np.floor(np.log10(gain))
    return float(max(m for m in (1, 2, 5) if m * power <= gain) * power)


def error_map(result: Evaluation, path: Path, move: int = 0, *, subject: str) -> Path:
    """Write :func:`error_map_figure` to ``path``."""
    return save_figure(error_map_figure(result, move, subject=subject), path)


def error_map_figure(result: Evaluation, move: int = 0, *, subject: str) -> Figure:
    """Error after ``move`` at each target position, three projections (colour = mm, log); every
    trial is drawn, those that stopped before ``move`` (error where they stopped) as large
    crosses in the same colours, outlined in black so that they stand out."""
    mm = np.maximum(result.distances[:, move] * 1e3, 1e-3)  # log colour scale: 1 µm floor
    made = result.moves_made > move
    t = result.target_pos
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6), layout="constrained")
    norm = matplotlib.colors.LogNorm(vmin=mm.min(), vmax=max(mm.max(), mm.min() * 1.01))
    for ax, (i, j, name) in zip(axes, PROJECTIONS, strict=True):
        for keep, style in ((made, {"marker": "o", "s": 14}), (~made, STOPPED_MAP_STYLE)):
            sc = ax.scatter(t[keep, i], t[keep, j], c=mm[keep], cmap="viridis", norm=norm, **style)
        ax.set_xlabel("xyz"[i] + " [m]")
        ax.set_ylabel("xyz"[j] + " [m]")
        ax.set_title(name)
        ax.set_aspect("equal", adjustable="datalim")
    fig.colorbar(sc, ax=axes, label=f"error after {_move_name(move)} [mm] (X: stopped earlier)")
    fig.suptitle(
        f"Error after the {_move_name(move)} move at each target ({len(t)} targets)\n{subject}",
        fontsize=11,
    )
    return fig


def save_figure(fig: Figure, path: Path, dpi: int = 120, bbox_inches: str | None = "tight") -> Path:
    """Write ``fig`` as an image at ``path`` (folders made as needed; the format from its
    suffix), atomically (:func:`learners.persistence.write_atomic`: a failed write leaves the
    old file or none), close it, return the path.

    ``bbox_inches="tight"`` crops the image to the drawn content; None keeps the figure's size.

    Raises:
        OutputError: no space, or a read-only or forbidden folder.
    """
    path = Path(path)
    kind = path.suffix.lstrip(".") or None  # None: matplotlib's default, png
    try:
        write_atomic(path, lambda f: fig.savefig(f, format=kind, dpi=dpi, bbox_inches=bbox_inches))
    finally:
        plt.close(fig)
    return path
