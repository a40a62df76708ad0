"""Evaluation figures (matplotlib, headless): learning curve, error histogram, the lattice in a
camera image, reached positions in 3-D, and an error map across the workspace.

Each figure is built by a ``*_figure`` function that returns the matplotlib Figure (tests read
its titles, labels and lines), and written by the function of the plain name through
:func:`save_figure`.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from envs.harness.evaluation import Evaluation

MOVE_NAMES = ("coarse", "fine 1", "fine 2", "fine 3", "fine 4")


def _move_name(k: int) -> str:
    return MOVE_NAMES[k] if k < len(MOVE_NAMES) else f"fine {k}"


def learning_curve(rows: list[dict], reach: float, path: Path) -> Path:
    """Write :func:`learning_curve_figure` to ``path``."""
    return save_figure(learning_curve_figure(rows, reach), path)


def learning_curve_figure(rows: list[dict], reach: float) -> Figure:
    """Held-out mean error (all trials) after each move vs training trials, log scale (mm and
    % reach): one line per move, one point per evaluation row.

    Args:
        rows: evaluation rows with ``trial`` and ``mean_mm`` (one error per move, mm).
        reach: the arm's reach (m), for the right axis in % of reach.
    """
    trials = np.array([r["trial"] for r in rows])
    errors = np.array([r["mean_mm"] for r in rows])  # (evals, moves)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
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
    ax.set_title("Learning curve (held-out targets)")
    return fig


def error_histogram(result: Evaluation, path: Path) -> Path | None:
    """Write :func:`error_histogram_figure` to ``path``; None (nothing written) when it has no
    figure."""
    fig = error_histogram_figure(result)
    return None if fig is None else save_figure(fig, path)


def error_histogram_figure(result: Evaluation) -> Figure | None:
    """Distribution of the distance to the target after each move over all trials (a trial that
    stopped counts where it stopped; log-spaced bins, mm); None when fewer than two errors are
    above 0 (no log-spaced bins)."""
    mm = result.distances * 1e3
    positive = mm[mm > 0]
    if positive.size < 2:
        return None
    floor = positive.min()  # exact zeros go into the lowest bin of the log axis
    bins = np.logspace(np.log10(floor), np.log10(positive.max()), 40)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for k in range(result.moves):
        ax.hist(np.maximum(mm[:, k], floor), bins=bins, alpha=0.55, label=_move_name(k))
    ax.set_xscale("log")
    ax.set_xlabel("distance to target [mm]")
    ax.set_ylabel("trials")
    ax.legend()
    stopped = int((~result.complete).sum())
    ax.set_title(f"Errors on {len(mm)} held-out targets ({stopped} stopped early, counted)")
    return fig


def lattice_in_image(
    w: np.ndarray, lattice: tuple[int, ...], image: np.ndarray, path: Path, camera: int = 0
) -> Path:
    """Write :func:`lattice_in_image_figure` to ``path``."""
    return save_figure(lattice_in_image_figure(w, lattice, image, camera), path)


def lattice_in_image_figure(
    w: np.ndarray, lattice: tuple[int, ...], image: np.ndarray, camera: int = 0
) -> Figure:
    """The neurons' w_r in one camera's image with lattice edges, as in Kohonen's Fig. 3b.

    Args:
        w: the neurons' camera coordinates (neurons, 4) pixels, C order over ``lattice``.
        lattice: the lattice shape.
        image: the camera image (height, width, 3) drawn beneath.
        camera: 0 left (columns 0, 1 of ``w``), 1 right (columns 2, 3).
    """
    grid = w.reshape(*lattice, -1)[..., 2 * camera : 2 * camera + 2]  # (*lattice, 2) pixels
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    ax.imshow(image, alpha=0.55)
    for axis in range(len(lattice)):
        lines = np.moveaxis(grid, axis, -2).reshape(-1, lattice[axis], 2)
        for line in lines:
            ax.plot(line[:, 0], line[:, 1], "-", color="tab:blue", lw=0.6, alpha=0.8)
    flat = grid.reshape(-1, 2)
    ax.plot(flat[:, 0], flat[:, 1], ".", color="navy", ms=2.5)
    ax.set_xlim(0, image.shape[1])
    ax.set_ylim(image.shape[0], 0)
    ax.set_title(
        f"Lattice {'x'.join(map(str, lattice))} in camera {'left' if camera == 0 else 'right'}"
    )
    return fig


def reached_3d(result: Evaluation, path: Path) -> Path:
    """Write :func:`reached_3d_figure` to ``path``."""
    return save_figure(reached_3d_figure(result), path)


def reached_3d_figure(result: Evaluation) -> Figure:
    """Targets and the positions where the arm ended (after the last move, or where the trial
    stopped), in 3-D (m)."""
    fig = plt.figure(figsize=(6.4, 5.2))
    ax = fig.add_subplot(projection="3d")
    t = result.target_pos
    ax.scatter(*t.T, s=6, c="tab:red", label="target", depthshade=False)
    ok = result.complete
    ax.scatter(*result.reached[ok].T, s=3, c="tab:green", label="reached", depthshade=False)
    if not ok.all():
        stop = result.reached[~ok]
        ax.scatter(*stop.T, s=8, c="k", marker="x", label="stopped early", depthshade=False)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend()
    ax.set_title("Targets and reached positions")
    return fig


def error_map(result: Evaluation, path: Path, move: int = 0) -> Path:
    """Write :func:`error_map_figure` to ``path``."""
    return save_figure(error_map_figure(result, move), path)


def error_map_figure(result: Evaluation, move: int = 0) -> Figure:
    """Error after ``move`` at each target position, three projections (colour = mm, log); every
    trial is drawn, those that stopped before ``move`` (error where they stopped) as crosses."""
    mm = np.maximum(result.distances[:, move] * 1e3, 1e-3)  # log colour scale: 1 µm floor
    made = result.moves_made > move
    t = result.target_pos
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.8))
    norm = matplotlib.colors.LogNorm(vmin=mm.min(), vmax=max(mm.max(), mm.min() * 1.01))
    for ax, (i, j, name) in zip(axes, ((0, 1, "x-y"), (0, 2, "x-z"), (1, 2, "y-z")), strict=True):
        for keep, marker in ((made, "o"), (~made, "x")):
            sc = ax.scatter(
                t[keep, i], t[keep, j], c=mm[keep], s=10, marker=marker, cmap="viridis", norm=norm
            )
        ax.set_xlabel("xyz"[i] + " [m]")
        ax.set_ylabel("xyz"[j] + " [m]")
        ax.set_title(name)
        ax.set_aspect("equal", adjustable="datalim")
    fig.colorbar(sc, ax=axes, label=f"error after {_move_name(move)} [mm] (x: stopped earlier)")
    return fig


def save_figure(fig: Figure, path: Path, dpi: int = 120, bbox_inches: str | None = "tight") -> Path:
    """Write ``fig`` as an image at ``path`` (folders made as needed), close it, return the path.

    ``bbox_inches="tight"`` crops the image to the drawn content; None keeps the figure's size.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches=bbox_inches)
    plt.close(fig)
    return path
