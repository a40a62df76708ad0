"""Table and plot of the map-vs-RL comparison (``envs.studies.rl_comparison`` curves)."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from envs.harness.plots import save_figure
from envs.studies.rl_comparison import THRESHOLDS, Curve, steps_to_reach

LABELS = {"map": "visuomotor map", "sac_her": "SAC + HER", "sac": "SAC", "ppo": "PPO"}
COLOURS = {"map": "C0", "sac_her": "C1", "sac": "C3", "ppo": "C2"}  # the same in every plot
MM, MS = 1e3, 1e3  # m -> mm, s -> ms


def group(curves: list[Curve]) -> dict[str, list[Curve]]:
    """Curves by method, in the order first seen."""
    out: dict[str, list[Curve]] = {}
    for c in curves:
        out.setdefault(c.method, []).append(c)
    return out


def table(curves: list[Curve]) -> str:
    """Markdown: final mean/median distance at the budget (mean ± sd over seeds for the mean),
    steps to reach each threshold, training wall time per env step."""
    head = " | ".join(f"steps to {t * MM:g} mm" for t in THRESHOLDS)
    lines = [
        f"| method | seeds | env steps | mean final [mm] | median final [mm] | {head} | "
        "train ms / env step |",
        "|---|---|---|---|---|" + "---|" * len(THRESHOLDS) + "---|",
    ]
    for method, runs in group(curves).items():
        final = np.array([c.mean_m[-1] for c in runs]) * MM
        median = np.mean([c.median_m[-1] for c in runs]) * MM
        reached = [steps_to_reach(runs, t) for t in THRESHOLDS]
        cells = " | ".join("not reached" if s is None else f"{s:,}" for s in reached)
        ms = np.mean([c.train_seconds / c.steps[-1] for c in runs]) * MS
        spread = f" ± {final.std(ddof=1):.2f}" if len(runs) > 1 else ""
        lines.append(
            f"| {LABELS.get(method, method)} | {len(runs)} | {runs[0].steps[-1]:,} | "
            f"{final.mean():.2f}{spread} | {median:.2f} | {cells} | {ms:.2f} |"
        )
    return "\n".join(lines)


def load(path: Path) -> dict[tuple[str, str, str], list[Curve]]:
    """Curves of a ``curves.jsonl`` by (env, sensing, control), in the order written."""
    out: dict[tuple[str, str, str], list[Curve]] = {}
    for line in path.read_text().splitlines():
        row = json.loads(line)
        key = (row.pop("env"), row.pop("sensing"), row.pop("control"))
        out.setdefault(key, []).append(Curve(**row))
    return out


def report(folder: Path, targets: int) -> str:
    """Table (markdown) and one plot per env and setting from ``folder/curves.jsonl``; writes
    ``folder/table.md`` and ``folder/<env>_<sensing>_<control>.png``; returns the table."""
    sections = []
    for (env_id, sensing, control), curves in load(folder / "curves.jsonl").items():
        title = f"{env_id} ({sensing}, {control}), {targets} held-out targets"
        plot(curves, title, folder / f"{env_id}_{sensing}_{control}.png")
        sections.append(f"### {title}\n\n{table(curves)}\n")
    text = "\n".join(sections)
    (folder / "table.md").write_text(text)
    return text


def plot(curves: list[Curve], title: str, path: Path) -> Path:
    """Write :func:`figure` to ``path``."""
    return save_figure(figure(curves, title), path, bbox_inches=None)


def figure(curves: list[Curve], title: str) -> Figure:
    """Mean final distance vs env steps, log-log: one line per method (the mean over its seeds,
    one point per checkpoint), the band the range of the seeds, and a dotted line per
    threshold."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for method, runs in group(curves).items():
        steps = np.mean([c.steps for c in runs], axis=0)
        mm = np.array([c.mean_m for c in runs]) * MM  # (seeds, checkpoints)
        colour = COLOURS[method]
        label = f"{LABELS[method]} ({len(runs)} seed{'s' if len(runs) > 1 else ''})"
        ax.loglog(steps, mm.mean(axis=0), marker="o", ms=3, color=colour, label=label)
        if len(runs) > 1:
            ax.fill_between(steps, mm.min(axis=0), mm.max(axis=0), color=colour, alpha=0.2)
    for t in THRESHOLDS:
        ax.axhline(t * MM, color="grey", lw=0.6, ls=":")
    ax.set_xlabel("environment steps (moves)")
    ax.set_ylabel("mean final distance [mm]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    ax.set_title(title)
    fig.tight_layout()
    return fig
