"""Benchmark the exact baselines against the SOM: time per single query and batch throughput.

    .venv/bin/python scripts/bench_ik.py                 # every robot, 20 000 batch targets
    .venv/bin/python scripts/bench.py ik --batch 5000    # the same through the benchmark dispatcher

Targets are drawn from each robot's workspace (seeded) and projected by its stereo rig
(``envs.StereoRig``); every controller gets the same pixels. AnalyticIK is the peer: ratios are
its time divided by the other's (> 1: the other is faster). Each timing is the best of
``--repeats`` runs (the machine may be shared). The SOM is a ``VisuomotorSOM`` of the default
lattice at the end of its schedule (t = t_max), as after training: its output averaging, and so
its speed, depends on the neighbourhood width σ'(t), not on the learned values.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import envs  # noqa: F401  (chooses the GL back-end before mujoco is imported)
from envs import StereoRig
from envs.cli import common as cli
from envs.cli import options
from envs.robots import ROBOTS
from envs.sizes import format_lattice
from learners.baselines.analytic_ik import AnalyticIK
from learners.baselines.jacobian_ik import JacobianIK
from learners.som.controller import VisuomotorSOM
from models import load_model


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = cli.parser(__doc__)
    p.add_argument("--robots", nargs="+", choices=tuple(ROBOTS), default=list(ROBOTS))
    cli.add_count(p, "--single", 500, "queries timed one by one")
    cli.add_count(p, "--batch", 20_000, "queries in one act_batch call")
    cli.add_count(p, "--repeats", 3, "timings repeated, best kept")
    options.SEED.add(p)
    return p.parse_args(argv)


def make_som(arm_lower: np.ndarray, arm_upper: np.ndarray, pixels: np.ndarray) -> VisuomotorSOM:
    """A VisuomotorSOM at the end of its schedule (t = t_max), as a trained map is used."""
    som = VisuomotorSOM(
        arm_lower,
        arm_upper,
        rng=0,
        input_low=pixels.min(axis=0) - 1,
        input_high=pixels.max(axis=0) + 1,
    )
    som.t = som.t_max
    return som


def time_single(controller, U: np.ndarray, repeats: int) -> float:
    """Seconds per ``act(u)``, each query after ``reset()`` as in a trial; best of ``repeats``."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        for u in U:
            controller.reset()
            controller.act(u)
        best = min(best, (time.perf_counter() - start) / len(U))
    return best


def time_batch(controller, U: np.ndarray, repeats: int) -> float:
    """Queries per second of one ``act_batch(U)``; best of ``repeats``."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        controller.act_batch(U)
        best = min(best, time.perf_counter() - start)
    return len(U) / best


def bench_robot(name: str, args: argparse.Namespace) -> None:
    import mujoco

    model = load_model(name)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rig = StereoRig(model, data)
    rng = np.random.default_rng(args.seed)
    targets = ROBOTS[name].workspace.sample(rng, max(args.single, args.batch))
    U = rig.project(targets)
    joints = ROBOTS[name].joint_options[0]  # the fewest controlled joints (3 for both arms)
    controllers = {
        "AnalyticIK": AnalyticIK.for_robot(rig.triangulate, name, joints),
        "JacobianIK": JacobianIK.for_robot(rig.triangulate, name, joints),
    }
    arm = controllers["AnalyticIK"].arm
    som = make_som(arm.lower, arm.upper, U)
    controllers["SOM " + format_lattice(som.lattice)] = som
    rows = {}
    for label, c in controllers.items():
        rows[label] = (
            time_single(c, U[: args.single], args.repeats),
            time_batch(c, U[: args.batch], args.repeats),
        )
    peer_single, peer_batch = rows["AnalyticIK"]
    print(f"\n{name}: {args.single} single queries, batch of {args.batch}")
    ratio = "× Analytic"
    print(f"{'controller':<14} {'µs/query':>10} {ratio:>11} {'batch q/s':>12} {ratio:>11}")
    for label, (single, batch) in rows.items():
        print(
            f"{label:<14} {1e6 * single:>10.1f} {peer_single / single:>11.3f} "
            f"{batch:>12.0f} {batch / peer_batch:>11.3f}"
        )
    jac = controllers["JacobianIK"]
    jac.act_batch(U[: args.batch])
    print(
        f"JacobianIK batch: converged {100 * np.mean(jac.last_reachable):.2f} %, "
        f"mean {np.mean(jac.last_iterations):.2f} iterations"
    )
    rig.close()


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    for name in args.robots:
        bench_robot(name, args)


#: Console entry point ``visuomotor-bench-ik``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
