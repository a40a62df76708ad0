"""Figures of a re-adaptation run (:mod:`envs.studies.adaptation`): error against trials, and a
video of trials before the change, just after it and after recovery, side by side."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from envs.harness.plots import save_figure
from envs.harness.trials import Trial, run_trial
from envs.harness.video import VideoWriter, annotate

FINE = 2  # column of the fine-2 error in the summaries
RECOVERED = 1.2  # "back": within this factor of the error before the change
LINEAR_BELOW = 0.01  # mm: the plots' y axis is linear below this (exact baselines sit at 0)
FRAMES_PER_MOVE = 3
STYLES = {
    "map, standard schedule": dict(color="C0"),
    "map, continual mode": dict(color="C1"),
    "map frozen": dict(color="C0", ls=":"),
    "AnalyticIK stale": dict(color="C3", ls="--"),
    "JacobianIK stale": dict(color="C4", ls="-."),
    "AnalyticIK recalibrated": dict(color="k", ls=(0, (1, 3))),
}


def curves_figure(pre: list[dict], results: list[dict[str, Any]], title: str, path: Path) -> Path:
    """Write :func:`adaptation_curves` to ``path``."""
    return save_figure(adaptation_curves(pre, results, title), path, dpi=110)


def adaptation_curves(pre: list[dict], results: list[dict[str, Any]], title: str) -> Figure:
    """One panel per change: held-out fine-2 error (mm) against all trials, the pre-training
    curve up to the change, every learning controller's curve after it, and the level of every
    controller that does not learn.

    Args:
        pre: evaluation rows (``trial``, ``mean_mm``) of the training before the change.
        results: one study result per change (``change``, ``config``, ``curves``, ``before``,
            ``after``), as :mod:`envs.studies.adaptation` returns them.
        title: the figure's title.
    """
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.8), sharey=True)
    axes = np.atleast_1d(axes)
    t0 = pre[-1]["trial"]
    for ax, result in zip(axes, results, strict=True):
        ax.plot([r["trial"] for r in pre], [r["mean_mm"][FINE] for r in pre], color="C0")
        end = t0 + result["config"]["after_trials"]
        for name, curve in result["curves"].items():
            x = [t0 + r["trial"] for r in curve]
            ax.plot(x, [r["mean_mm"][FINE] for r in curve], marker="o", ms=2, label=name,
                    **STYLES[name])  # fmt: skip
        for name in (
            "map frozen",
            "AnalyticIK stale",
            "JacobianIK stale",
            "AnalyticIK recalibrated",
        ):
            level = result["after"][name]["mean_mm"][FINE]
            ax.plot([t0, end], [level, level], label=name, **STYLES[name])
        before = result["before"]["map"]["mean_mm"][FINE]
        ax.axhline(RECOVERED * before, color="0.6", lw=0.8, label=f"{RECOVERED}× map before")
        ax.axvline(t0, color="0.3", lw=0.8)
        ax.set_xlim(max(0, t0 - result["config"]["after_trials"]), end)
        ax.set_yscale("symlog", linthresh=LINEAR_BELOW)
        ax.set_title(result["change"], fontsize=9)
        ax.set_xlabel("training trials (change at the vertical line)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("held-out mean error after fine move 2 [mm]")
    axes[-1].legend(fontsize=7, loc="upper right")
    fig.suptitle(title, fontsize=10)
    return fig


def phases_video(
    env_id: str,
    options: dict[str, Any],
    phases: list[tuple[str, dict[str, Any], Any]],
    path: Path,
    trials: int = 3,
    seed: int = 1,
    fps: float = 6.0,
) -> Path:
    """The same ``trials`` targets in each phase, the left camera views side by side.

    Args:
        env_id, options: the env (``gym.make(env_id, **options)``).
        phases: (label, change for ``perturb``, controller) per panel.
    """
    envs, frames = [], []
    try:
        for label, change, controller in phases:
            env = gym.make(env_id, render_mode="rgb_array", **options)
            envs.append(env)
            env.unwrapped.perturb(change)
            env.reset(seed=seed)
            panels: list[np.ndarray] = []
            for _ in range(trials):
                shots: list[np.ndarray] = []

                def record(k: int, trial: Trial, env=env, label=label, shots=shots) -> None:
                    move = "target" if k < 0 else ("coarse" if k == 0 else f"fine {k}")
                    error = "" if k < 0 else f"  {trial.distances[k] * 1e3:.1f} mm"
                    width = env.unwrapped.image_width
                    shots.append(annotate(env.render()[:, :width], [label, move + error], 0.4))

                run_trial(env, controller, FINE, on_move=record)
                # A trial that stopped (marker not seen) holds its last frame: phases stay aligned.
                panels += shots + shots[-1:] * (FINE + 2 - len(shots))
            frames.append(panels)
        with VideoWriter(path, fps) as video:
            for row in zip(*frames, strict=True):
                frame = np.concatenate(row, axis=1)
                for _ in range(FRAMES_PER_MOVE):
                    video.write(frame)
    finally:
        for env in envs:
            env.close()
    return Path(path)
