"""The figure of the redundancy study: the swivel angle the map chose over the workspace.

One colour scale in degrees. Above: the neurons' tcp positions (the forward kinematics of their
θ_r) seen from above (x-y) and from the side (x-z), with the lattice's neighbour links, coloured
by their swivel angle, and the held-out targets seen from above, coloured by the swivel angle of
each trial's last command. Below: each neuron's swivel angle over the lattice, one grid over its
first two axes per index of the third, where a jump between neighbours shows as an edge.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from envs.harness.plots import save_figure, subject
from envs.robots import robot_of_env
from envs.studies.redundancy import Redundancy, neighbour_steps

#: The neurons' panels: (horizontal axis, vertical axis, name).
VIEWS = ((0, 1, "from above"), (0, 2, "from the side"))
LINK_STYLE: dict[str, Any] = {"colors": "0.6", "linewidths": 0.4, "alpha": 0.5, "zorder": 1}
CMAP = "viridis"
#: Dots per inch of the written figure (1400 x 840 px).
DPI = 100


def links(points: np.ndarray, lattice: tuple[int, ...]) -> np.ndarray:
    """The segments (pairs, 2, 3) between lattice neighbours of points (N, 3), C order."""
    grid = points.reshape(*lattice, 3)
    segments = []
    for a in range(len(lattice)):
        start = np.delete(grid, -1, axis=a).reshape(-1, 3)
        end = np.delete(grid, 0, axis=a).reshape(-1, 3)
        segments.append(np.stack((start, end), axis=1))
    return np.concatenate(segments)


def figure(result: Redundancy) -> Figure:
    """The panels of ``result`` (module docstring)."""
    swivel = np.degrees(result.swivel)
    final = np.degrees(result.final_swivel)
    norm = matplotlib.colors.Normalize(
        vmin=min(swivel.min(), final.min()), vmax=max(swivel.max(), final.max())
    )
    layers = _layers(swivel, result.lattice)
    fig = plt.figure(figsize=(14, 8.4), layout="constrained")
    columns = 3 * len(layers)  # a multiple of both rows' panel counts
    grid = fig.add_gridspec(2, columns, height_ratios=(1.2, 1.0))
    axes = [fig.add_subplot(grid[0, k * len(layers) : (k + 1) * len(layers)]) for k in range(3)]
    cells = [fig.add_subplot(grid[1, k * 3 : (k + 1) * 3]) for k in range(len(layers))]
    segments = links(result.tcp, result.lattice)
    for ax, (i, j, name) in zip(axes, VIEWS, strict=False):
        ax.add_collection(LineCollection(list(segments[..., [i, j]]), **LINK_STYLE))
        ax.scatter(result.tcp[:, i], result.tcp[:, j], c=swivel, s=22, cmap=CMAP, norm=norm,
                   edgecolors="0.3", linewidths=0.3, zorder=2)  # fmt: skip
        ax.set_title(f"neurons' tcp {name}, lattice links", fontsize=10)
    axes[2].scatter(result.target_pos[:, 0], result.target_pos[:, 1], c=final, s=9, cmap=CMAP,
                    norm=norm)  # fmt: skip
    axes[2].set_title(f"{len(final)} held-out targets from above:\nψ of the last command",
                      fontsize=10)  # fmt: skip
    for ax, (i, j) in zip(axes, ((0, 1), (0, 2), (0, 1)), strict=True):
        ax.set_xlabel("xyz"[i] + " [m]")
        ax.set_ylabel("xyz"[j] + " [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.autoscale_view()
    for k, (ax, layer) in enumerate(zip(cells, layers, strict=True)):
        image = ax.imshow(layer.T, origin="lower", cmap=CMAP, norm=norm)
        ax.set_xlabel("lattice index, axis 1")
        if k == 0:
            ax.set_ylabel("axis 2")
        ax.set_title(f"ψ of each neuron, lattice layer {k + 1}/{len(layers)}", fontsize=10)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    fig.colorbar(image, ax=[*axes, *cells], label="swivel angle ψ [°] (0: elbow up)", shrink=0.8)
    jump = np.degrees(neighbour_steps(result.swivel, result.lattice, circular=True).max())
    shape = "×".join(map(str, result.lattice))
    line = subject(robot_of_env(result.env), result.sensing, result.control, "VisuomotorSOM")
    fig.suptitle(
        f"Swivel angle chosen by the map ({shape} lattice; largest jump between neighbours "
        f"{jump:.1f}°)\n{line}",
        fontsize=11,
    )
    return fig


def _layers(values: np.ndarray, lattice: tuple[int, ...]) -> list[np.ndarray]:
    """Per neuron values (N,) as 2-D grids over the first two lattice axes, one per index of
    the third (a lattice of one or two axes: one grid)."""
    shape = (*lattice, 1, 1)[:3]
    grid = values.reshape(shape)
    return [grid[:, :, k] for k in range(shape[2])]


def write(result: Redundancy, path: Path) -> Path:
    """Write :func:`figure` to ``path`` (atomically, :func:`~envs.harness.plots.save_figure`)."""
    return save_figure(figure(result), path, dpi=DPI)
