"""Re-adaptation after a change of the scene: the learned map against the stale exact baselines.

One run: train a map for ``train_trials`` trials; apply a change (:mod:`envs.perturb`) to the
training env and to the evaluation env; go on training for ``after_trials`` trials, evaluating on
the same held-out targets every ``every`` trials. Compared on those targets: the map learning on
(with the standard schedules and in the continual mode, side by side), a frozen copy of the map
as it was at the change, ``AnalyticIK`` and ``JacobianIK`` with the nominal (stale)
calibration, and the exact IK re-calibrated on the changed scene (an oracle,
:class:`envs.studies.recalibrated_oracle.RecalibratedIK`). The controllers that do not learn are
evaluated once after the change (their commands are deterministic, so every later evaluation would
repeat it). Every mean counts all trials (``envs.harness.evaluation``).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

from envs.harness.evaluation import evaluate
from envs.harness.streams import seed_env
from envs.harness.training import RunConfig, initial_map
from envs.harness.trials import learn_from, run_trial
from envs.studies.recalibrated_oracle import RecalibratedIK
from learners.baselines.analytic_ik import AnalyticIK
from learners.baselines.jacobian_ik import JacobianIK
from learners.som.controller import VisuomotorSOM
from learners.som.schedules import Continual

#: The named changes a study can apply: camera moved 5 cm and turned 3°, focal length +5 %, tool
#: 5 cm longer, base moved 5 cm; "none" for the no-change control.
CHANGES: dict[str, dict[str, Any]] = {
    "camera": {"camera_shift": [0.05, 0.0, 0.0], "camera_turn": [0.0, 0.0523599, 0.0]},
    "zoom": {"zoom": 1.05},
    "tool": {"tool": 0.05},
    "base": {"base_shift": [0.05, 0.0, 0.0]},
    "none": {},
}
MAP_STANDARD, MAP_CONTINUAL = "map, standard schedule", "map, continual mode"

Progress = Callable[[str, int], None]


@dataclass(frozen=True)
class AdaptConfig:
    """One adaptation run: the pre-training ``run`` (env, sensing, control, seed, ``trials``,
    lattice; ``eval_every`` for its learning curve; ``eval_trials`` held-out targets and
    ``fine_moves`` for every evaluation) and what follows it (all fields JSON-ready)."""

    run: RunConfig = field(default_factory=lambda: RunConfig(eval_every=2000, eval_trials=1000))
    change: str = "camera"
    after_trials: int = 3000
    every: int = 250  # trials between evaluations after the change
    extra: dict[str, Any] = field(default_factory=dict)  # a change not in CHANGES, if given


def train(env, som: VisuomotorSOM, trials: int) -> None:
    """``trials`` training trials (coarse + one exploring fine move, then ``learn``)."""
    for _ in range(trials):
        learn_from(som, run_trial(env, som, fine_moves=1, explore=True))


def pretrain(
    config: AdaptConfig, progress: Progress | None = None
) -> tuple[VisuomotorSOM, list[dict[str, Any]]]:
    """A map trained on the nominal scene for ``config.run.trials`` trials, watching its sensed
    error for the continual mode (which changes nothing before t_max), and its held-out learning
    curve every ``config.run.eval_every`` trials (rows ``{"trial", **summary}``)."""
    run = config.run
    env, eval_env = run.make_env(), run.make_env("evaluation")
    try:
        som = initial_map(run, env, continual=Continual())
        curve = [{"trial": 0, **held_out(eval_env, som, config)}]
        while curve[-1]["trial"] < run.trials:
            n = min(run.eval_every, run.trials - curve[-1]["trial"])
            train(env, som, n)
            curve.append({"trial": curve[-1]["trial"] + n, **held_out(eval_env, som, config)})
            if progress is not None:
                progress("pre-training", curve[-1]["trial"])
    finally:
        env.close()
        eval_env.close()
    return som, curve


def warm_up(
    config: AdaptConfig, som: VisuomotorSOM, trials: int, progress: Progress | None = None
) -> tuple[VisuomotorSOM, list[dict[str, Any]]]:
    """Carry a map trained elsewhere (e.g. in the idealised setting) into ``config``'s setting:
    a copy with a restarted error monitor, trained ``trials`` trials on the nominal scene, so
    that the continual mode's reference is this setting's error. Returns that map and the
    held-out curve at the start and the end (rows ``{"trial", **summary}``, trials counted from
    the map's first); ``som`` is not changed."""
    env, eval_env = config.run.make_env(), config.run.make_env("evaluation")
    try:
        som = som.with_config(continual=Continual())
        seen = som.t + sum(som.skipped.values())
        curve = [{"trial": seen, **held_out(eval_env, som, config)}]
        train(env, som, trials)
        curve.append({"trial": seen + trials, **held_out(eval_env, som, config)})
        if progress is not None:
            progress("warm-up", trials)
    finally:
        env.close()
        eval_env.close()
    return som, curve


def held_out(env, controller, config: AdaptConfig) -> dict[str, Any]:
    """Summary of ``config.run.eval_trials`` trials on the fixed held-out targets."""
    run = config.run
    seed_env(env, run.seed, "evaluation")
    summary = evaluate(env, controller, run.eval_trials, run.fine_moves).summary()
    controller.reset()
    summary.pop("microseconds_per_query", None)  # wall time: would make reruns differ
    return summary


def adapt(
    config: AdaptConfig, som: VisuomotorSOM, progress: Progress | None = None
) -> tuple[dict[str, Any], dict[str, VisuomotorSOM]]:
    """Run the change and the re-adaptation for a map from :func:`pretrain` (not changed).

    Two copies of the map learn on after the change, side by side: the standard schedules
    (floors from t_max on, as published) and the continual mode (:class:`Continual`).

    Returns:
        ``{"config", "change", "before": {name: summary}, "after": {name: summary},
        "curves": {map name: [{"trial", **summary}, ...]}}``: before = the map and the
        baselines on the nominal scene; after = the controllers that do not learn, on the
        changed scene; curves = each learning map at 0, every, 2·every, ... trials after the
        change; and the two maps as they are at the end.
    """
    env, eval_env = config.run.make_env(), config.run.make_env("evaluation")
    try:
        base = eval_env.unwrapped
        stale = {
            "AnalyticIK stale": AnalyticIK.for_robot(
                base.nominal_stereo.triangulate, base.robot, base.joints
            ),
            "JacobianIK stale": JacobianIK.for_robot(
                base.nominal_stereo.triangulate, base.robot, base.joints
            ),
        }
        before = {"map": held_out(eval_env, som, config)}
        before.update({name: held_out(eval_env, c, config) for name, c in stale.items()})
        change = config.extra or CHANGES[config.change]
        applied = base.perturb(change)
        env.unwrapped.perturb(change)
        learning = {
            MAP_STANDARD: som.with_config(continual=None),
            MAP_CONTINUAL: copy.deepcopy(som),
        }
        frozen = copy.deepcopy(som)
        static = {"map frozen": frozen, **stale, "AnalyticIK recalibrated": RecalibratedIK(base)}
        after = {name: held_out(eval_env, c, config) for name, c in static.items()}
        curves = {}
        for name, learner in learning.items():
            curve = [{"trial": 0, **after["map frozen"]}]
            while curve[-1]["trial"] < config.after_trials:
                n = min(config.every, config.after_trials - curve[-1]["trial"])
                train(env, learner, n)
                curve.append(
                    {"trial": curve[-1]["trial"] + n, **held_out(eval_env, learner, config)}
                )
                if progress is not None:
                    progress(f"{config.change}: {name}", curve[-1]["trial"])
            curves[name] = curve
        after["map frozen (end)"] = held_out(eval_env, frozen, config)
    finally:
        env.close()
        eval_env.close()
    result = {
        "config": asdict(config),
        "change": applied.describe(),
        "before": before,
        "after": after,
        "curves": curves,
        "readaptations": learning[MAP_CONTINUAL].monitor.readaptations,
    }
    return result, learning


def trials_to_recover(result: dict[str, Any], name: str, factor: float = 1.2) -> int | None:
    """First evaluation (trials after the change) at which map ``name``'s fine-2 error is within
    ``factor`` of the map's before the change; None if it never is within the run."""
    goal = factor * result["before"]["map"]["mean_mm"][-1]
    return next((r["trial"] for r in result["curves"][name] if r["mean_mm"][-1] <= goal), None)


def table_row(result: dict[str, Any]) -> dict[str, Any]:
    """The figures of one run, fine-2 mean errors in mm (JSON-ready)."""
    fine = {name: s["mean_mm"][-1] for name, s in result["after"].items()}
    row = {
        "env": result["config"]["run"]["env"],
        "change": result["change"],
        "map before": result["before"]["map"]["mean_mm"][-1],
        "just after": fine["map frozen"],
    }
    for name in (MAP_STANDARD, MAP_CONTINUAL):
        row[f"{name}: trials to 1.2x"] = trials_to_recover(result, name)
        row[f"{name}: end"] = result["curves"][name][-1]["mean_mm"][-1]
    for name in ("AnalyticIK stale", "JacobianIK stale", "AnalyticIK recalibrated"):
        row[name] = fine[name]
    row["complete trials (continual, end)"] = result["curves"][MAP_CONTINUAL][-1]["complete_trials"]
    row["trials"] = result["curves"][MAP_CONTINUAL][-1]["trials"]
    return row


def markdown_table(rows: list[dict[str, Any]]) -> str:
    """The rows of :func:`table_row` as a Markdown table (fine-2 mean errors in mm)."""

    def trials(n: int | None) -> str:
        return "—" if n is None else f"{n:,}"

    lines = [
        "| arm | change | before | just after | standard: trials to 1.2× | standard: after "
        "| continual: trials to 1.2× | continual: after | AnalyticIK stale | JacobianIK stale "
        "| re-calibrated |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['env'].replace('Reach-v0', '')} | {r['change']} | {r['map before']:.2f} "
            f"| {r['just after']:.2f} | {trials(r[f'{MAP_STANDARD}: trials to 1.2x'])} "
            f"| {r[f'{MAP_STANDARD}: end']:.2f} | {trials(r[f'{MAP_CONTINUAL}: trials to 1.2x'])} "
            f"| {r[f'{MAP_CONTINUAL}: end']:.2f} | {r['AnalyticIK stale']:.1f} "
            f"| {r['JacobianIK stale']:.1f} | {r['AnalyticIK recalibrated']:.3f} |"
        )
    return "\n".join(lines) + "\n"
