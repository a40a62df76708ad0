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
#: The end of an error arrow cut at the axes: an open black diamond.
CUT_STYLE = {"marker": "D", "s": 40, "facecolors": "none", "edgecolors": "black", "linewidths": 1,
             "clip_on": False}  # fmt: skip
#: Error arrows over this many times the median error do not set the axes (they are cut).
FAR_FACTOR = 5.0
AXES_MARGIN = 0.05  # of the larger side of the box round targets and arrows
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
    ax.set_ylabel("mean error [mm]")  # error: the distance of the sensed point from the target
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
    ax.set_xlabel("error [mm]")
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
    w: np.ndarray,
    lattice: tuple[int, ...],
    image: np.ndarray,
    camera: int = 0,
    layer: int | None = None,
    *,
    subject: str,
) -> Figure:
    """The neurons' w_r in one camera's image, as in Kohonen's Fig. 3b: every neuron a dot, and
    the edges of one layer of the lattice (all edges of a lattice of one or two axes): the
    layers of a 3-D lattice drawn together are a tangle that shows nothing.

    Args:
        w: the neurons' camera coordinates (neurons, 4) pixels, C order over ``lattice``.
        lattice: the lattice shape.
        image: the camera image (height, width, 3) drawn beneath.
        camera: 0 left (columns 0, 1 of ``w``), 1 right (columns 2, 3).
        layer: the index along the lattice's last axis of the layer drawn with edges (default:
            the middle one).
    """
    grid = w.reshape(*lattice, -1)[..., 2 * camera : 2 * camera + 2]  # (*lattice, 2) pixels
    shape = "x".join(map(str, lattice))
    if len(lattice) >= 3:
        layer = lattice[-1] // 2 if layer is None else layer
        if not 0 <= layer < lattice[-1]:
            raise ValueError(f"layer {layer} is not in 0..{lattice[-1] - 1} of lattice {shape}")
        edges = grid[..., layer, :]  # (*lattice[:-1], 2)
        drawn = f"edges of layer {layer + 1} of {lattice[-1]} along the last axis"
    else:
        edges, drawn = grid, "edges"
    fig, ax = plt.subplots(figsize=(6.4, 5.2), layout="constrained")
    ax.imshow(image)
    flat = grid.reshape(-1, 2)
    ax.plot(flat[:, 0], flat[:, 1], ".", color="navy", ms=2.5, alpha=0.7, label="all neurons")
    for axis in range(edges.ndim - 1):
        lines = np.moveaxis(edges, axis, -2).reshape(-1, edges.shape[axis], 2)
        for k, line in enumerate(lines):
            label = drawn if axis == 0 and k == 0 else None
            ax.plot(line[:, 0], line[:, 1], "-", color="tab:orange", lw=0.8, label=label)
    ax.set_xlim(0, image.shape[1])
    ax.set_ylim(image.shape[0], 0)
    ax.set_xlabel("u [px]")
    ax.set_ylabel("v [px]")
    ax.legend(loc="lower right", fontsize=8)
    side = "left" if camera == 0 else "right"
    ax.set_title(f"Lattice {shape} in camera {side}\n{subject}", fontsize=10)
    return fig


def error_vectors(result: Evaluation, path: Path, *, subject: str) -> Path:
    """Write :func:`error_vectors_figure` to ``path``."""
    return save_figure(error_vectors_figure(result, subject=subject), path)


def error_vectors_figure(result: Evaluation, *, subject: str) -> Figure:
    """Where the arm ended relative to each target, three projections: an arrow from the target
    to the end point (after the last move, or where the trial stopped), magnified by one factor
    for all (stated in the title) so that millimetre errors show on a workspace of decimetres,
    coloured by the error (mm, log scale); trials that stopped early are marked by crosses.

    The axes are set by the targets and the arrows of the bulk of the trials: an arrow whose
    error is over :data:`FAR_FACTOR` times the median (a trial stopped far off, a wild move) is
    cut where it leaves the axes and its cut end marked, the count in the legend, so that a few
    far points do not squash the rest into a corner.
    """
    t, reached = result.target_pos, result.reached  # (n, 3) m each
    error = reached - t  # (n, 3) m
    norms = np.linalg.norm(error, axis=1)  # m
    mm = np.maximum(norms * 1e3, 1e-3)  # log colour scale: 1 µm floor
    span = float(np.ptp(t, axis=0).max()) or 1.0  # m
    typical = float(np.median(norms))  # m
    gain = _round_gain(0.06 * span / typical) if typical > 0 else 1.0
    far = norms > FAR_FACTOR * typical if typical > 0 else np.zeros(len(t), dtype=bool)
    stopped = ~result.complete
    norm = matplotlib.colors.LogNorm(vmin=mm.min(), vmax=max(mm.max(), mm.min() * 1.01))
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6), layout="constrained")
    for ax, (i, j, name) in zip(axes, PROJECTIONS, strict=True):
        arrows = gain * error[:, [i, j]]  # (n, 2) m
        low, high = _bulk_limits(t[:, [i, j]], t[~far][:, [i, j]] + arrows[~far])
        shown = arrows * _cut(t[:, [i, j]], arrows, low, high)[:, None]
        quiver = ax.quiver(
            t[:, i], t[:, j], shown[:, 0], shown[:, 1], mm,
            cmap="viridis", norm=norm, angles="xy", scale_units="xy", scale=1, width=0.004,
        )  # fmt: skip
        cut = far & np.any(np.abs(shown - arrows) > 1e-12, axis=1)
        ends = t[cut][:, [i, j]] + shown[cut]
        label = f"arrow cut at the axes ({cut.sum()}: error > {FAR_FACTOR:g}× median)"
        ax.scatter(ends[:, 0], ends[:, 1], label=label, **CUT_STYLE)
        ax.scatter(t[stopped, i], t[stopped, j], label="stopped early", **STOPPED_STYLE)
        ax.set_xlim(low[0], high[0])
        ax.set_ylim(low[1], high[1])
        ax.set_xlabel("xyz"[i] + " [m]")
        ax.set_ylabel("xyz"[j] + " [m]")
        ax.set_title(name)
        ax.set_aspect("equal", adjustable="box")  # the limits stay; the panel's shape gives
        if stopped.any() or far.any():
            ax.legend(loc="best", fontsize=8)
    fig.colorbar(quiver, ax=axes, label="error after the last move [mm]")
    fig.suptitle(f"Target → end point, arrows ×{gain:g} ({len(t)} targets)\n{subject}", fontsize=11)
    return fig


def _bulk_limits(targets: np.ndarray, tips: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) (2,) m: the box round every target and the bulk's arrow tips, with a margin
    of :data:`AXES_MARGIN` of its larger side (and at least 1 mm)."""
    points = np.concatenate([targets, tips])
    low, high = points.min(axis=0), points.max(axis=0)
    margin = max(AXES_MARGIN * float((high - low).max()), 1e-3)
    return low - margin, high + margin


def _cut(start: np.ndarray, arrow: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """(n,) the share in [0, 1] of each arrow from ``start`` (inside the box) that stays inside
    the box [low, high] (2,)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(arrow > 0, (high - start) / arrow, (low - start) / arrow)
    room = np.where(arrow == 0, np.inf, room)
    return np.clip(room.min(axis=1), 0.0, 1.0)


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
