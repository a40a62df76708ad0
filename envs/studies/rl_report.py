"""Table and plot of the map-vs-RL comparison (``envs.studies.rl_comparison`` curves)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from envs.harness.plots import save_figure
from envs.reach import MAX_EPISODE_STEPS
from envs.studies import rl_runs
from envs.studies.rl_comparison import (
    METHODS,
    SUCCESS_THRESHOLDS,
    THRESHOLDS,
    VARIANTS,
    Curve,
    steps_to_reach,
    success_key,
)
from learners.persistence import write_atomic

LABELS = {
    "map": "visuomotor map",
    "sac_her": "SAC + HER",
    "sac": "SAC",
    "ppo": "PPO",
    "sac_pixels": "SAC on images",
}
#: the same in every plot
COLOURS = {"map": "C0", "sac_her": "C1", "sac": "C3", "ppo": "C2", "sac_pixels": "C4"}
VARIANT_LABELS = {"g2": "2 gradient steps / env step", "gamma0.5": "γ 0.5", "gamma0": "γ 0"}
VARIANT_STYLES = {"zoo": "-", "g2": "--", "gamma0.5": "-.", "gamma0": ":"}
LEGACY_FILE = "curves.jsonl"  # the comparison's output before runs had folders
MM, MS = 1e3, 1e3  # m -> mm, s -> ms


def label(curve: Curve) -> str:
    """The method's name, with its variant and episode length when not the defaults."""
    notes = [VARIANT_LABELS.get(curve.variant, curve.variant)] if curve.variant != "zoo" else []
    if curve.episode_steps != MAX_EPISODE_STEPS:
        notes.append(f"{curve.episode_steps}-move episodes")
    text = LABELS.get(curve.method, curve.method)
    return f"{text} ({', '.join(notes)})" if notes else text


def group(curves: list[Curve]) -> dict[str, list[Curve]]:
    """Curves by :func:`label`, in the order first seen, each cut to the checkpoints all of its
    seeds have reached (runs still under way have fewer)."""
    out: dict[str, list[Curve]] = {}
    for c in curves:
        out.setdefault(label(c), []).append(c)
    for name, runs in out.items():
        reached = min(len(c.steps) for c in runs)
        out[name] = [c if len(c.steps) == reached else rl_runs.truncated(c, reached) for c in runs]
    return out


def at_step(curve: Curve, steps: int | None) -> int:
    """Index of the last checkpoint at or below ``steps`` (the last one for None)."""
    if steps is None:
        return len(curve.steps) - 1
    return max(int(np.searchsorted(curve.steps, steps, side="right")) - 1, 0)


def table(curves: list[Curve], at: int | None = None) -> str:
    """Markdown: mean/median final distance at the budget, or at the last checkpoint at or
    below ``at`` env steps (mean ± sd over seeds for the mean), the success fractions there when
    the curves have them, steps to reach each threshold, training wall time per env step."""
    head = " | ".join(f"steps to {t * MM:g} mm" for t in THRESHOLDS)
    successes = all(c.success for c in curves)
    keys = [success_key(t) for t in SUCCESS_THRESHOLDS] if successes else []
    success_head = "".join(f" success < {t * MM:g} mm |" for t in SUCCESS_THRESHOLDS[: len(keys)])
    lines = [
        f"| method | seeds | env steps | mean final [mm] | median final [mm] |{success_head} "
        f"{head} | train ms / env step |",
        "|---|---|---|---|---|" + "---|" * (len(keys) + len(THRESHOLDS)) + "---|",
    ]
    for name, runs in group(curves).items():
        i = [at_step(c, at) for c in runs]
        final = np.array([c.mean_m[k] for c, k in zip(runs, i, strict=True)]) * MM
        median = np.mean([c.median_m[k] for c, k in zip(runs, i, strict=True)]) * MM
        rates = [np.mean([c.success[key][k] for c, k in zip(runs, i, strict=True)]) for key in keys]
        success = "".join(f" {r:.0%} |" for r in rates)
        reached = [steps_to_reach(runs, t) for t in THRESHOLDS]
        cells = " | ".join("not reached" if s is None else f"{s:,}" for s in reached)
        ms = np.mean([c.train_seconds / c.steps[-1] for c in runs]) * MS
        spread = f" ± {final.std(ddof=1):.2f}" if len(runs) > 1 else ""
        lines.append(
            f"| {name} | {len(runs)} | {runs[0].steps[i[0]]:,} | "
            f"{final.mean():.2f}{spread} | {median:.2f} |{success} {cells} | {ms:.2f} |"
        )
    return "\n".join(lines)


Setting = tuple[str, str, str]  # env, sensing, control


def load(path: Path) -> dict[Setting, list[Curve]]:
    """Curves of a ``curves.jsonl`` by (env, sensing, control), in the order written."""
    out: dict[Setting, list[Curve]] = {}
    for line in path.read_text().splitlines():
        row = json.loads(line)
        key = (row.pop("env"), row.pop("sensing"), row.pop("control"))
        out.setdefault(key, []).append(Curve(**row))
    return out


def load_folder(folder: Path) -> dict[Setting, list[Curve]]:
    """The curves of ``folder/curves.jsonl`` (if any), then of its runs
    (``envs.studies.rl_runs``; those under way up to their last checkpoint), by (env, sensing,
    control)."""
    out = load(folder / LEGACY_FILE) if (folder / LEGACY_FILE).is_file() else {}
    runs = sorted(rl_runs.saved_runs(folder), key=lambda run: _order(run[1]))
    for spec, curve, _ in runs:
        out.setdefault((spec.env, spec.sensing, spec.control), []).append(curve)
    return out


def _order(curve: Curve) -> tuple:
    """Longer episodes first, then methods and variants in their declared order, then seeds."""
    known = [*METHODS, curve.method]
    return (
        -curve.episode_steps,
        known.index(curve.method),
        [*VARIANTS, curve.variant].index(curve.variant),
        curve.seed,
    )


def has_runs(folder: Path) -> bool:
    """Whether ``folder`` holds anything to report."""
    return bool(load_folder(folder))


def report(folder: Path, targets: int, table_at: list[int] | None = None) -> str:
    """Table (markdown) and one plot per env and setting from ``folder``'s curves
    (:func:`load_folder`); writes ``folder/table.md`` and ``folder/<env>_<sensing>_<control>.png``;
    returns the table. ``table_at``: also tabulate at these env steps."""
    sections = []
    for (env_id, sensing, control), curves in load_folder(folder).items():
        title = f"{env_id} ({sensing}, {control}), {targets} held-out targets"
        plot(curves, title, folder / f"{env_id}_{sensing}_{control}.png")
        for at in [*(table_at or []), None]:
            where = "" if at is None else f", at {at:,} env steps"
            sections.append(f"### {title}{where}\n\n{table(curves, at)}\n")
    text = "\n".join(sections)
    write_atomic(folder / "table.md", lambda f: f.write(text.encode()))
    return text


def plot(curves: list[Curve], title: str, path: Path) -> Path:
    """Write :func:`figure` to ``path``."""
    return save_figure(figure(curves, title), path, bbox_inches=None)


def figure(curves: list[Curve], title: str) -> Figure:
    """Mean final distance vs env steps, log-log: one line per method and variant (the mean over
    its seeds, one point per checkpoint; variants in other line styles), the band the range of
    the seeds, and a dotted line per threshold; one panel per episode length when there are
    several. Curves with success fractions get a row under it per success threshold: the share
    of episodes below it, mean over seeds."""
    lengths = sorted({c.episode_steps for c in curves}, reverse=True)
    success_at = SUCCESS_THRESHOLDS if all(c.success for c in curves) else ()
    fig, axes = plt.subplots(
        1 + len(success_at),
        len(lengths),
        figsize=(6.4 * len(lengths), 4.2 + 1.5 * len(success_at)),
        sharex="col",
        squeeze=False,
        gridspec_kw={"height_ratios": [2.4] + [1] * len(success_at)},
    )
    for col, length in enumerate(lengths):
        ax = axes[0][col]
        for runs in group([c for c in curves if c.episode_steps == length]).values():
            first = runs[0]
            steps = np.mean([c.steps for c in runs], axis=0)
            mm = np.array([c.mean_m for c in runs]) * MM  # (seeds, checkpoints)
            line = {"color": COLOURS[first.method], "ls": VARIANT_STYLES.get(first.variant, "-")}
            ax.loglog(steps, mm.mean(axis=0), marker="o", ms=3, label=_legend(first, len(runs),
                      with_episode=len(lengths) == 1), **line)  # fmt: skip
            if len(runs) > 1:
                ax.fill_between(steps, mm.min(axis=0), mm.max(axis=0), color=line["color"],
                                alpha=0.2)  # fmt: skip
            for row, t in enumerate(success_at, start=1):
                rate = np.mean([c.success[success_key(t)] for c in runs], axis=0)
                axes[row][col].semilogx(steps, rate, marker="o", ms=3, **line)
        for t in THRESHOLDS:
            ax.axhline(t * MM, color="grey", lw=0.6, ls=":")
        ax.legend(fontsize="small")
        ax.set_title(title if len(lengths) == 1 else f"{title}\n{length}-move episodes")
        for a in axes[:, col]:
            a.grid(True, which="both", alpha=0.3)
        axes[-1][col].set_xlabel("environment steps (moves)")
        for row, t in enumerate(success_at, start=1):
            axes[row][col].set_ylim(-0.03, 1.03)
            axes[row][col].set_ylabel(f"share < {t * MM:g} mm")
        ax.set_ylabel("mean final distance [mm]")
    fig.tight_layout()
    return fig


def _legend(curve: Curve, seeds: int, with_episode: bool) -> str:
    """:func:`label` (without the episode length when each length has its own panel) and the
    number of seeds."""
    name = label(curve) if with_episode else label(replace(curve, episode_steps=MAX_EPISODE_STEPS))
    count = f"{seeds} seed{'s' if seeds > 1 else ''}"
    return f"{name[:-1]}, {count})" if name.endswith(")") else f"{name} ({count})"
