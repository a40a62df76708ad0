"""Training with workers measured: trials per second for several numbers of workers in the same
run, the learned maps' held-out errors against the one-process map's, the learner's own time per
trial as a share of a worker's (what limits a cluster of many workers), and the held-out errors
against the round size (how stale a worker's map may be; docs/decisions.md, "Workers").
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from envs.harness.evaluation import evaluate
from envs.harness.training import RunConfig, Trainer
from envs.harness.workers import InProcessPool, WorkerPool


def held_out_mm(config: RunConfig, som: Any, targets: int) -> list[float]:
    """Mean errors (mm) after the coarse and each fine move on ``targets`` held-out targets of
    the run's seed (``config.fine_moves`` fine moves)."""
    env = config.make_env("evaluation")
    try:
        return list(evaluate(env, som, targets, config.fine_moves).summary()["mean_mm"])
    finally:
        env.close()
        som.reset()


def _run(
    config: RunConfig, out: Path, round_trials: int | None = None, local: bool = True
) -> dict[str, Any]:
    """Train ``config`` in ``out``: the trained Trainer (closed) and trials per second after the
    first round (start-up, the workers' own and the first held-out evaluation, left out)."""
    trainer = Trainer(config, out)
    if round_trials is not None:
        trainer.round_trials = round_trials
    trainer.make_pool = WorkerPool if local else InProcessPool
    marks: list[tuple[int, float]] = []

    def progress(trial: int, running: dict[str, float]) -> None:
        marks.append((trial, time.perf_counter()))

    try:
        trainer.run(progress=progress)
    finally:
        trainer.close()
    (first, start), (last, end) = marks[0], marks[-1]
    rate = (last - first) / (end - start) if end > start else float("nan")
    return {"trainer": trainer, "trials_per_s": rate}


def benchmark(config: RunConfig, counts: list[int], targets: int) -> dict[str, Any]:
    """Train ``config`` once for each number of workers in ``counts`` (1: the one-process
    training) and evaluate each map on ``targets`` held-out targets.

    Returns per count: trials/s, held-out mean errors (mm) per move and their ratio to the
    first count's, and for N >= 2 a worker's time per trial, the learner's (learning and
    sending the map) and its share of the worker's; with the load average before and after.
    """
    load_before = os.getloadavg()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_workers-") as scratch:
        for n in counts:
            run = _run(replace(config, workers=n), Path(scratch) / f"n{n}")
            trainer = run.pop("trainer")
            row: dict[str, Any] = {"workers": n, "trials_per_s": round(run["trials_per_s"], 2)}
            row["held_out_mm"] = [round(x, 4) for x in held_out_mm(config, trainer.som, targets)]
            spent = trainer.spent
            if spent is not None and spent.trials:
                worker = spent.worker_seconds / spent.trials
                learner = (trainer.learner_seconds + spent.send_seconds) / spent.trials
                row |= {
                    "worker_ms_per_trial": round(worker * 1e3, 3),
                    "learner_ms_per_trial": round(learner * 1e3, 4),
                    "learner_share_percent": round(100 * learner / worker, 3),
                    "restarts": spent.restarts,
                }
            rows.append(row)
    base = rows[0]["held_out_mm"]
    for row in rows:
        row["held_out_ratio"] = [
            round(x / b, 4) for x, b in zip(row["held_out_mm"], base, strict=True)
        ]
    return {
        "config": config.to_stored(),
        "targets": targets,
        "rows": rows,
        "cores": os.cpu_count(),
        "load_average_before": [round(x, 2) for x in load_before],
        "load_average_after": [round(x, 2) for x in os.getloadavg()],
    }


def round_sizes(
    config: RunConfig, sizes: list[int], seeds: list[int], targets: int
) -> dict[str, Any]:
    """Held-out mean errors (mm per move) of maps trained with rounds of each of ``sizes``
    trials (0: the one-process training, trial after trial), for each of ``seeds``; the rounds
    run in this process (a round's trials do not depend on who runs them)."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="round_sizes-") as scratch:
        for size in sizes:
            errors = []
            for seed in seeds:
                run_config = replace(config, seed=seed, workers=1 if size == 0 else 2)
                out = Path(scratch) / f"r{size}-s{seed}"
                trainer = _run(run_config, out, size or None, local=False)["trainer"]
                errors.append(held_out_mm(run_config, trainer.som, targets))
            mean = [
                round(sum(e[k] for e in errors) / len(errors), 4) for k in range(len(errors[0]))
            ]
            rows.append({"round_trials": size, "mean_mm": mean, "per_seed_mm": errors})
    return {"config": config.to_stored(), "targets": targets, "seeds": seeds, "rows": rows}
