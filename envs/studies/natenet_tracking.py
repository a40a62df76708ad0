"""NATEnet on PumaTrack-v0 against the exact inverse Jacobian, a fixed-grid net of the same
size (no allocation) and the untrained net: training on random paths, tracking unseen circles
and lines, the acceptance figures, plots and a video. :func:`track_study` runs it all for a
:class:`TrackingStudy`; ``scripts/train_natenet.py`` is its command line.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np

from envs.harness.plots import save_figure
from envs.harness.tracking import evaluate, exact_inverse_jacobian, track_episode, train_on_paths
from envs.harness.video import VideoWriter, annotate
from envs.track import PumaTrackEnv
from learners import natenet as nn
from learners.natenet import NATEnet, PathTracker, grid_counts
from learners.persistence import write_atomic

matplotlib.use("Agg")
import matplotlib.pyplot as plt

#: Seed offsets that keep training and test paths apart.
TRAIN_SEEDS, CIRCLE_SEEDS, LINE_SEEDS = 0, 1_000_000, 2_000_000
TEST_RADIUS = 0.1  # m, the acceptance circle
ACCEPT_MM, ACCEPT_DEG = 2.0, 1.0  # acceptance: mean position (mm) and orientation (°) error
#: Lower ends of the log-scale error axes (the untrained arm passes through 0 at the circle's end).
PLOT_FLOOR_MM, PLOT_FLOOR_DEG = 1e-3, 1e-4


@dataclass(frozen=True)
class TrackingStudy:
    """The settings of one study (the program's options, in its order: ``metrics.json`` keeps
    them under "args")."""

    out: Path
    seed: int = 0
    train_paths: int = 300
    test_paths: int = 10  # per test set (circles, lines)
    exploration: float = 0.01  # rad, joint noise std of the training commands
    input_dim: int = 5  # θ1..θ5 (θ6 does not change J) or all six joints
    lam: float = nn.LAMBDA
    eta: float = nn.ETA
    T0: float = nn.T0
    e_f: float = nn.E_F
    tau: float = nn.TAU
    T_a: float = nn.T_A
    max_nodes: int = nn.MAX_NODES
    gain: float = nn.GAIN
    sensing: str = "project"
    no_video: bool = False


#: A progress display: (items, what, unit) -> the same items (the command line's shows a bar).
Progress = Callable[[Iterable[Any], str, str], Iterable[Any]]


def _silent(items: Iterable[Any], what: str, unit: str) -> Iterable[Any]:
    return items


def track_study(args: TrackingStudy, progress: Progress = _silent) -> dict:
    """Train, evaluate, report, and write ``metrics.json``, the nets, the plots and the video
    into ``args.out``; returns the metrics."""
    args.out.mkdir(parents=True, exist_ok=True)
    params = dict(lam=args.lam, eta=args.eta, T0=args.T0, e_f=args.e_f, tau=args.tau, T_a=args.T_a)
    train_env = PumaTrackEnv(sensing=args.sensing, path_kind="any")
    circle_env = PumaTrackEnv(sensing=args.sensing, path_kind="circle", circle_radius=TEST_RADIUS)
    line_env = PumaTrackEnv(sensing=args.sensing, path_kind="line")
    seeds = args.seed * 10_000 + TRAIN_SEEDS + np.arange(args.train_paths)

    def train(net: NATEnet, what: str) -> dict:
        paths = progress(seeds, what, "path")
        rng = np.random.default_rng(args.seed)
        return train_on_paths(train_env, net, paths, args.exploration, rng, args.gain)

    start = time.perf_counter()
    net = NATEnet(input_dim=args.input_dim, max_nodes=args.max_nodes, **params)
    history = train(net, "NATEnet training")
    train_time = time.perf_counter() - start
    print(f"NATEnet: {net.n_nodes} nodes after {net.steps} learning steps ({train_time:.1f} s)")

    # The grid spans the joint box of the training paths, with no more nodes than NATEnet.
    lower = history["joint_lower"][: args.input_dim]
    upper = history["joint_upper"][: args.input_dim]
    counts = grid_counts(lower, upper, net.n_nodes)
    grid = NATEnet.fixed_grid(lower, upper, counts, **params)
    grid_history = train(grid, "fixed-grid training")
    print(f"fixed grid: {grid.n_nodes} nodes, {counts.tolist()} per joint")

    trackers = {
        "exact inverse Jacobian": PathTracker(exact_inverse_jacobian, args.gain),
        "NATEnet": PathTracker.from_net(net, args.gain),
        "fixed grid": PathTracker.from_net(grid, args.gain),
        "untrained": PathTracker.from_net(NATEnet(input_dim=args.input_dim), args.gain),
    }
    circle_seeds = CIRCLE_SEEDS + args.seed * 10_000 + np.arange(args.test_paths)
    line_seeds = LINE_SEEDS + args.seed * 10_000 + np.arange(args.test_paths)
    evals = {
        name: {
            "circle": evaluate(circle_env, tr, progress(circle_seeds, name, "circle")),
            "line": evaluate(line_env, tr, progress(line_seeds, name, "line")),
        }
        for name, tr in trackers.items()
    }
    metrics = {
        "args": {k: str(v) for k, v in asdict(args).items()},
        "nodes": net.n_nodes,
        "grid_nodes": grid.n_nodes,
        "grid_counts": counts.tolist(),
        "learning_steps": net.steps,
        "train_time_s": train_time,
        "node_history": {k: history[k].tolist() for k in ("steps", "nodes")},
        "tracking": {
            name: {kind: summary(ev) for kind, ev in e.items()} for name, e in evals.items()
        },
    }
    metrics["acceptance"] = acceptance(metrics)
    report(metrics)
    net.save(args.out / "natenet.npz")
    grid.save(args.out / "fixed_grid.npz")
    plot_results(args.out, evals, history, grid_history)
    if not args.no_video:
        metrics["video"] = str(write_video(args.out, net, args.gain, int(circle_seeds[0])))
    text = json.dumps(metrics, indent=2).encode()
    write_atomic(args.out / "metrics.json", lambda f: f.write(text))
    for env in (train_env, circle_env, line_env):
        env.close()
    print(f"wrote {args.out}")
    return metrics


def summary(ev: dict) -> dict:
    pos, ori = ev["position_mm"], ev["orientation_deg"]
    return {
        "position_mm_mean": float(pos.mean()),
        "position_mm_max": float(pos.max()),
        "position_mm_worst_path_mean": float(pos.mean(axis=1).max()),
        "orientation_deg_mean": float(ori.mean()),
        "orientation_deg_max": float(ori.max()),
        "command_time_us": ev["command_time"] * 1e6,
        "step_time_us": ev["step_time"] * 1e6,
    }


def acceptance(metrics: dict) -> dict:
    """The acceptance figures: NATEnet on unseen r = 0.1 m circles, 100 steps per revolution,
    against the ACCEPT_MM and ACCEPT_DEG bounds."""
    s = metrics["tracking"]["NATEnet"]["circle"]
    return {
        "position_mm_mean": s["position_mm_mean"],
        "orientation_deg_mean": s["orientation_deg_mean"],
        "nodes": metrics["nodes"],
        "step_time_us": s["step_time_us"],
        "command_time_us": s["command_time_us"],
        "passed": s["position_mm_mean"] <= ACCEPT_MM and s["orientation_deg_mean"] <= ACCEPT_DEG,
    }


def report(metrics: dict) -> None:
    for name, e in metrics["tracking"].items():
        for kind, s in e.items():
            print(
                f"{name:>24} {kind:>6}: position {s['position_mm_mean']:8.3f} mm mean "
                f"({s['position_mm_max']:8.3f} max), orientation "
                f"{s['orientation_deg_mean']:7.3f}° mean; {s['command_time_us']:6.1f} µs per "
                f"command, {s['step_time_us']:6.1f} µs per step"
            )
    a = metrics["acceptance"]
    print(
        f"NATEnet on r = {TEST_RADIUS} m circles: {a['position_mm_mean']:.3f} mm, "
        f"{a['orientation_deg_mean']:.3f}° mean error, {a['nodes']} nodes, "
        f"{a['step_time_us']:.0f} µs per step"
    )


def plot_results(out: Path, evals: dict, history: dict, grid_history: dict) -> None:
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for name, ev in evals.items():
        axes[0].semilogy(ev["circle"]["position_mm"][0], label=name)
        axes[1].semilogy(ev["circle"]["orientation_deg"][0], label=name)
    axes[0].set_ylabel("position error (mm)")
    axes[1].set_ylabel("orientation error (°)")
    axes[0].set_ylim(bottom=PLOT_FLOOR_MM)
    axes[1].set_ylim(bottom=PLOT_FLOOR_DEG)
    axes[1].set_xlabel("step along the test circle (r = 0.1 m)")
    axes[0].legend()
    fig.tight_layout()
    save_figure(fig, out / "tracking_error.png", bbox_inches=None)

    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(history["steps"], history["nodes"], label="NATEnet (allocation)")
    ax.plot(grid_history["steps"], grid_history["nodes"], "--", label="fixed grid")
    ax.set_xlabel("learning steps (moves)")
    ax.set_ylabel("nodes")
    ax.legend()
    fig.tight_layout()
    save_figure(fig, out / "node_count.png", bbox_inches=None)

    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    first = evals["NATEnet"]["circle"]["results"][0]
    ax.plot(*first.path.positions.T, "k-", lw=2, label="path")
    for name, ev in evals.items():
        tcp = ev["circle"]["results"][0].tcp_positions
        ax.plot(*tcp.T, lw=1, marker="o" if np.ptp(tcp) < 1e-6 else None, label=name)
    ax.set_box_aspect(np.maximum(np.ptp(first.path.positions, axis=0), 1e-3))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.legend()
    fig.tight_layout()
    save_figure(fig, out / "path_3d.png", bbox_inches=None)


def write_video(out: Path, net: NATEnet, gain: float, seed: int) -> Path:
    env = PumaTrackEnv(render_mode="rgb_array", path_kind="circle", circle_radius=TEST_RADIUS)
    try:
        res = track_episode(env, PathTracker.from_net(net, gain), seed=seed, record=True)
    finally:
        env.close()
    path = out / "tracked_circle.mp4"
    errors = np.concatenate([[0.0], res.position_errors])
    with VideoWriter(path, fps=PumaTrackEnv.metadata["render_fps"]) as video:
        for k, frame in enumerate(res.frames):
            video.write(
                annotate(
                    frame,
                    [
                        f"NATEnet ({net.n_nodes} nodes), step {k}",
                        f"position error {errors[k] * 1e3:.2f} mm",
                    ],
                )
            )
    return path
