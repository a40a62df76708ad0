"""Reach-env speed: steps per second for every robot × sensing × control, against Gymnasium's
``Reacher-v5`` measured in the same run, plus the cost of one rendered stereo sensing.

    .venv/bin/python scripts/bench_envs.py [--steps 200] [--json runs/bench_envs.json]
    .venv/bin/python scripts/bench.py envs [same options]

Each row: construct the env (not timed), reset it (not timed: this also starts the renderers),
then time ``--steps`` moves with random in-range commands drawn beforehand. The envs are stepped
unwrapped (no TimeLimit or checker), the peer too. Goals of issue 3: kinematic + project at least
as fast as Reacher-v5; render sensing of both 320×240 cameras within 15 ms a step.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import cli
import gymnasium as gym
import numpy as np

import envs  # noqa: F401  (chooses the GL back-end before mujoco is imported, registers the envs)
from envs.markers import GREEN_EFFECTOR, RED_TARGET
from envs.reach import CONTROL_MODES, IMAGE_HEIGHT, IMAGE_WIDTH, SENSING_MODES

ENV_IDS = {"riacs": "RiacsReach-v0", "puma560": "PumaReach-v0"}
PEER_ID = "Reacher-v5"
RENDER_GOAL_MS = 15.0  # ms per step with render sensing (issue 3)
MS_PER_S = 1e3


def time_steps(env: gym.Env, n_steps: int, seed: int) -> float:
    """Steps per second of ``n_steps`` random-action steps after a reset (the reset not timed)."""
    env.reset(seed=seed)
    space = env.action_space
    actions = np.random.default_rng(seed).uniform(space.low, space.high, (n_steps, *space.shape))
    start = time.perf_counter()
    for action in actions:
        env.step(action)
    return n_steps / (time.perf_counter() - start)


def time_sense(env_id: str, repeats: int, seed: int) -> dict[str, float]:
    """Milliseconds for one ``stereo.sense`` call (both cameras rendered), per marker."""
    env = gym.make(env_id, sensing="render", control="kinematic").unwrapped
    env.reset(seed=seed)
    out = {}
    for name, colour in (("target", RED_TARGET), ("effector", GREEN_EFFECTOR)):
        start = time.perf_counter()
        for _ in range(repeats):
            env.stereo.sense(env.data, colour)
        out[name] = (time.perf_counter() - start) / repeats * MS_PER_S
    env.close()
    return out


def peer_steps_per_second(n_steps: int, seed: int) -> float | None:
    """Reacher-v5 steps per second, or None (with a message) if Gymnasium's MuJoCo extras lack."""
    try:
        env = gym.make(PEER_ID).unwrapped
    except ImportError as exc:
        print(
            f"warning: {PEER_ID} unavailable ({exc}); install Gymnasium's MuJoCo extras with "
            "pip install 'gymnasium[mujoco]' (it needs imageio). Ratios are left out."
        )
        return None
    rate = time_steps(env, n_steps, seed)
    env.close()
    return rate


def run(steps: int, peer_steps: int, sense_repeats: int, seed: int) -> dict:
    """Measure every row, the peer and the sensing call; returns the JSON-ready results."""
    peer = peer_steps_per_second(peer_steps, seed)
    rows = []
    for robot, env_id in ENV_IDS.items():
        for sensing in SENSING_MODES:
            for control in CONTROL_MODES:
                env = gym.make(env_id, sensing=sensing, control=control).unwrapped
                rate = time_steps(env, steps, seed)
                env.close()
                rows.append(
                    {
                        "env": env_id,
                        "robot": robot,
                        "sensing": sensing,
                        "control": control,
                        "steps": steps,
                        "steps_per_s": rate,
                        "ms_per_step": MS_PER_S / rate,
                        "ratio_to_peer": None if peer is None else rate / peer,
                    }
                )
    sense = {robot: time_sense(env_id, sense_repeats, seed) for robot, env_id in ENV_IDS.items()}
    return {
        "peer": {"env": PEER_ID, "steps": peer_steps, "steps_per_s": peer},
        "rows": rows,
        "sense_ms": sense,
        "render_goal_ms": RENDER_GOAL_MS,
        "image": [IMAGE_WIDTH, IMAGE_HEIGHT],
        "machine": {"cpus": os.cpu_count(), "MUJOCO_GL": os.environ.get("MUJOCO_GL")},
    }


def format_table(results: dict) -> str:
    peer = results["peer"]["steps_per_s"]
    lines = [
        f"{'env':<15} {'sensing':<8} {'control':<10} {'steps/s':>9} {'ms/step':>8} "
        f"{'×' + PEER_ID:>12}",
    ]
    for r in results["rows"]:
        ratio = "n/a" if r["ratio_to_peer"] is None else f"{r['ratio_to_peer']:.3f}"
        lines.append(
            f"{r['env']:<15} {r['sensing']:<8} {r['control']:<10} {r['steps_per_s']:>9.1f} "
            f"{r['ms_per_step']:>8.2f} {ratio:>12}"
        )
    peer_text = "n/a" if peer is None else f"{peer:.1f} steps/s ({MS_PER_S / peer:.3f} ms/step)"
    lines.append(f"peer {PEER_ID}: {peer_text}")
    width, height = results["image"]
    for robot, ms in results["sense_ms"].items():
        lines.append(
            f"stereo.sense {robot} ({width}×{height}, 2 cameras): target {ms['target']:.2f} ms, "
            f"effector {ms['effector']:.2f} ms per call"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict:
    parser = cli.parser(__doc__)
    parser.add_argument(
        "--steps", type=cli.positive_int, default=200, help="timed moves per env row"
    )
    parser.add_argument(
        "--peer-steps", type=cli.positive_int, default=5000, help="timed Reacher-v5 steps"
    )
    parser.add_argument(
        "--sense-repeats", type=cli.positive_int, default=50, help="timed stereo.sense calls"
    )
    parser.add_argument("--seed", type=cli.nonnegative_int, default=0)
    parser.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = parser.parse_args(argv)
    for name in ("steps", "peer_steps", "sense_repeats"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1")
    results = run(args.steps, args.peer_steps, args.sense_repeats, args.seed)
    print(format_table(results))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(results, indent=2) + "\n")
        print(f"wrote {args.json}")
    return results


if __name__ == "__main__":
    cli.run(main)
