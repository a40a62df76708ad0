"""The figure of the grasp-learning study: error against training trials per leaf, log x.

Two panels (position in % of the PUMA's reach, orientation in degrees), one line per move
(coarse and each fine move) of the hierarchical map, with the published rows drawn across:
Martinetz & Schulten (1990), 0.3 % of the robot's size and 3.8° after fewer than two trial
movements per neuron, and Kuperstein (1988), 4 % and 4°. The exact pose IK floor sits near 0
(within rounding) and is named in the caption rather than drawn on the log axes.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

from envs.harness.plots import save_figure
from envs.studies.grasp_learning import Row

#: Published (position % of the robot's size, orientation °) with their labels.
PUBLISHED = (
    ("Martinetz & Schulten 1990", 0.3, 3.8, "k"),
    ("Kuperstein 1988", 4.0, 4.0, "C3"),
)


def figure(rows: list[Row], title: str) -> Figure:
    """The two panels of ``rows`` (the map's rows of :func:`~envs.studies.grasp_learning.table`;
    a floor row, with no training trials, is left out)."""
    learned = [r for r in rows if r.trials > 0]
    per_leaf = np.array([r.trials_per_leaf for r in learned])
    position = np.array([r.position_pct for r in learned])  # (budgets, moves)
    orientation = np.array([r.orientation_deg for r in learned])  # (budgets, moves)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    panels = ((position, "position error, % of reach", 1), (orientation, "orientation error, °", 2))
    for ax, (values, label, column) in zip(axes, panels, strict=True):
        for k in range(values.shape[1]):
            name = "coarse" if k == 0 else f"fine {k}"
            ax.plot(
                per_leaf, values[:, k], "o-", label=name, color=plt.cm.viridis(k / values.shape[1])
            )
        for paper, *published, colour in PUBLISHED:
            ax.axhline(published[column - 1], ls="--", color=colour, lw=1, label=paper)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(per_leaf, [f"{x:g}" for x in per_leaf])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 3.0, 5.0)))
        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("training trials per leaf")
        ax.set_ylabel(f"mean {label}")
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return fig


def write(rows: list[Row], title: str, path: Path) -> Path:
    """Write :func:`figure` to ``path`` (PNG)."""
    return save_figure(figure(rows, title), path, dpi=110)
