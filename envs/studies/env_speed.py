"""Reach-env speed against Gymnasium's ``Reacher-v5`` measured in the same run: steps per
second for every robot × sensing × control, the cost of one rendered stereo sensing, the RL
loop (``gym.make`` envs, random actions, resets at episode end) in alternating rounds, image
observations, ``render()`` frames, and SAC + HER against SAC. Each ``measure*`` and ``time_*``
function returns JSON-ready numbers; each ``format_*`` the table that
``scripts/bench_envs.py`` prints.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from importlib.util import find_spec

import gymnasium as gym
import numpy as np

import envs  # noqa: F401  (chooses the GL back-end before mujoco is imported, registers the envs)
from envs.reach import CONTROL_MODES, IMAGE_HEIGHT, IMAGE_WIDTH, SENSING_MODES
from envs.robots import ROBOTS, default_reach_env_ids
from envs.sensing.marker_detection import GREEN_EFFECTOR, RED_TARGET

#: The reach env of every robot of the default runs, by robot.
ENV_IDS = {name: spec.reach_env for name, spec in ROBOTS.items() if spec.default_runs}
PEER_ID = "Reacher-v5"
FOVEA_OFFSET = 0.01  # m, marker from target when timing foveated sensing (a fine move's error)
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
    """Milliseconds for one sensing of both cameras, per marker: whole 320×240 images
    (``stereo.sense``), and foveated effector sensing with windows about the target's sensed
    pixels, the arm placed so that its marker is FOVEA_OFFSET from the target (as after a
    reach), measured on the same poses in the same run."""
    env = gym.make(env_id, sensing="foveated", control="kinematic").unwrapped
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    poses = []  # (joints, target) with the marker in both images
    while len(poses) < repeats:
        q = rng.uniform(env.joint_lower, env.joint_upper)
        env.set_joints(q)
        marker = env.sensed_point()
        offset = rng.normal(size=3)
        target = marker + FOVEA_OFFSET * offset / np.linalg.norm(offset)
        uv = env.stereo.project(np.stack([marker, target]))  # (2, 4)
        inside = (uv[:, ::2] > 0) & (uv[:, ::2] < IMAGE_WIDTH - 1)
        inside &= (uv[:, 1::2] > 0) & (uv[:, 1::2] < IMAGE_HEIGHT - 1)
        if inside.all():
            poses.append((q, target))
    seconds = np.zeros((repeats, 3))  # target, effector whole images, effector foveated
    fell_back = np.zeros(repeats, dtype=bool)
    for i, (q, target) in enumerate(poses):
        env.data.mocap_pos[0] = target
        env.set_joints(q)
        start = time.perf_counter()
        expected, _ = env.stereo.sense(env.data, RED_TARGET)
        middle = time.perf_counter()
        env.stereo.sense(env.data, GREEN_EFFECTOR, env.marker_radius)
        end = time.perf_counter()
        fallbacks = env.fovea.fallbacks
        env.fovea.sense(env.data, GREEN_EFFECTOR, env.marker_radius, expected)
        seconds[i] = middle - start, end - middle, time.perf_counter() - end
        fell_back[i] = env.fovea.fallbacks > fallbacks
    env.close()
    ms = seconds.mean(axis=0) * MS_PER_S
    # Foveated calls that found the marker in (or hidden inside) the windows, without rendering
    # the whole images: the cost of a step after a reach; the others rendered both.
    windowed = seconds[~fell_back, 2].mean() * MS_PER_S if (~fell_back).any() else float("nan")
    return {
        "target": ms[0],
        "effector": ms[1],
        "effector_foveated": ms[2],
        "effector_foveated_windows_only": windowed,
        "foveated_fallbacks": int(fell_back.sum()),
    }


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


RL_ENVS = default_reach_env_ids()
RL_SETTING = {"sensing": "project", "control": "kinematic"}
US_PER_S = 1e6
CLOCKS = {"wall": time.perf_counter, "thread": time.thread_time}  # s


def rl_loop(
    env: gym.Env, actions: np.ndarray, clock: Callable[[], float] = time.perf_counter
) -> tuple[float, float, int]:
    """Seconds (of ``clock``) in total and in resets, and the number of resets, for one pass of
    ``actions`` (the first reset, which seeds the env, is not timed)."""
    reset_s, resets = 0.0, 0
    start = clock()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            t = clock()
            env.reset()
            reset_s += clock() - t
            resets += 1
    return clock() - start, reset_s, resets


def time_rl_loop(n_steps: int, rounds: int, seed: int, clock: str = "wall") -> list[dict]:
    """The RL loop for each of RL_ENVS and PEER_ID, ``rounds`` alternating passes each, timed
    with ``CLOCKS[clock]``."""
    makers = {env_id: lambda e=env_id: gym.make(e, **RL_SETTING) for env_id in RL_ENVS}
    makers[PEER_ID] = lambda: gym.make(PEER_ID)
    envs_, actions, totals = {}, {}, {}
    for env_id, make in makers.items():
        env = envs_[env_id] = make()
        env.reset(seed=seed)
        space = env.action_space
        rng = np.random.default_rng(seed)
        actions[env_id] = rng.uniform(space.low, space.high, (n_steps, *space.shape))
        totals[env_id] = np.zeros(3)  # total s, reset s, resets
    for _ in range(rounds):
        for env_id, env in envs_.items():
            totals[env_id] += rl_loop(env, actions[env_id], CLOCKS[clock])
    rows = []
    for env_id, (total, reset, resets) in totals.items():
        steps = n_steps * rounds
        rows.append(
            {
                "env": env_id,
                "transitions_per_s": steps / total,
                "steps_per_s": steps / (total - reset),
                "us_per_reset": reset / max(resets, 1) * US_PER_S,
                "resets": int(resets),
                "clock": clock,
            }
        )
        envs_[env_id].close()
    peer = rows[-1]
    for row in rows:
        row["ratio_with_resets"] = row["transitions_per_s"] / peer["transitions_per_s"]
        row["ratio_step_only"] = row["steps_per_s"] / peer["steps_per_s"]
        row["ratio_reset_cost"] = row["us_per_reset"] / peer["us_per_reset"]
    return rows


def format_rl_table(rows: list[dict]) -> str:
    lines = [
        f"RL loop (gym.make, random actions, reset at episode end; {RL_SETTING['sensing']}, "
        f"{RL_SETTING['control']}; {rows[0]['clock']} time); ratios against {PEER_ID} in the "
        "same run",
        f"{'env':<15} {'transitions/s':>13} {'×peer':>6} {'steps/s':>9} {'×peer':>6} "
        f"{'µs/reset':>9} {'×peer':>6}",
    ]
    for r in rows:
        lines.append(
            f"{r['env']:<15} {r['transitions_per_s']:>13.0f} {r['ratio_with_resets']:>6.2f} "
            f"{r['steps_per_s']:>9.0f} {r['ratio_step_only']:>6.2f} "
            f"{r['us_per_reset']:>9.1f} {r['ratio_reset_cost']:>6.2f}"
        )
    return "\n".join(lines)


def measure(steps: int, peer_steps: int, sense_repeats: int, seed: int) -> dict:
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
            f"effector {ms['effector']:.2f} ms per call; foveated effector "
            f"{ms['effector_foveated']:.2f} ms ({ms['effector_foveated'] / ms['effector']:.2f}× "
            f"whole images; {ms['foveated_fallbacks']} of the calls also rendered whole images, "
            f"the others {ms['effector_foveated_windows_only']:.2f} ms, "
            f"{ms['effector_foveated_windows_only'] / ms['effector']:.2f}×)"
        )
    return "\n".join(lines)


PIXELS = 84  # px, width and height of each camera image, and of the peer's rendered image
RENDER_FRAMES = 30
SB3_ENV = "RiacsReach-v0"


def time_pixel_steps(n_steps: int, seed: int) -> dict:
    """Steps/s of the reach envs with two 84×84 camera images against Reacher-v5 rendering one
    84×84 image as its observation, alternating env by env in one run."""
    makers = {
        env_id: lambda e=env_id: gym.make(e, obs_mode="pixels", **RL_SETTING).unwrapped
        for env_id in RL_ENVS
    }
    makers[PEER_ID] = lambda: gym.wrappers.AddRenderObservation(
        gym.make(PEER_ID, render_mode="rgb_array", width=PIXELS, height=PIXELS).unwrapped,
        render_only=True,
    )
    rates = {env_id: time_steps(make(), n_steps, seed) for env_id, make in makers.items()}
    peer = rates[PEER_ID]
    return {env_id: {"steps_per_s": r, "ratio_to_peer": r / peer} for env_id, r in rates.items()}


def time_render(frames: int, seed: int) -> dict:
    """Milliseconds per ``render()`` frame (rgb_array, default size): wall and process CPU."""
    out = {}
    for env_id in RL_ENVS:
        env = gym.make(env_id, render_mode="rgb_array", **RL_SETTING)
        env.reset(seed=seed)
        env.render()  # starts the renderer (not timed)
        wall = cpu = 0.0
        for _ in range(frames):
            env.step(env.action_space.sample())
            w, c = time.perf_counter(), time.process_time()
            frame = env.render()
            wall += time.perf_counter() - w
            cpu += time.process_time() - c
        env.close()
        out[env_id] = {
            "shape": list(frame.shape),
            "ms_wall": wall / frames * MS_PER_S,
            "ms_cpu": cpu / frames * MS_PER_S,
        }
    return out


def time_sac_her(n_steps: int, rounds: int, seed: int) -> dict | None:
    """ms of process CPU time per env step of SAC + HER and of SAC (learning after 100 steps,
    one gradient step per env step), alternating; None without the rl extra."""
    if find_spec("stable_baselines3") is None:
        print("SAC + HER: skipped, the rl extra is not installed (pip install -e '.[rl]')")
        return None
    import torch
    from stable_baselines3 import SAC, HerReplayBuffer

    torch.set_num_threads(1)
    her = {
        "replay_buffer_class": HerReplayBuffer,
        "replay_buffer_kwargs": {"n_sampled_goal": 4, "copy_info_dict": True},
    }
    totals = {"sac": 0.0, "sac_her": 0.0}
    for _ in range(rounds):
        for name, extra in (("sac", {}), ("sac_her", her)):
            env = gym.make(SB3_ENV, **RL_SETTING)
            model = SAC(
                "MultiInputPolicy", env, seed=seed, device="cpu", learning_starts=100,
                buffer_size=10 * n_steps, **extra,
            )  # fmt: skip
            start = time.process_time()
            model.learn(n_steps)
            totals[name] += time.process_time() - start
            env.close()
    ms = {name: t / (n_steps * rounds) * MS_PER_S for name, t in totals.items()}
    return {"env": SB3_ENV, "ms_per_step": ms, "ratio": ms["sac_her"] / ms["sac"]}


def format_agents(results: dict) -> str:
    lines = [f"image observations (2 × {PIXELS}×{PIXELS} px) against {PEER_ID} + "
             f"AddRenderObservation ({PIXELS}×{PIXELS}), same run:"]  # fmt: skip
    for env_id, r in results["pixels"].items():
        lines.append(
            f"  {env_id:<15} {r['steps_per_s']:>8.1f} steps/s  ×peer {r['ratio_to_peer']:.2f}"
        )
    for env_id, r in results["render"].items():
        lines.append(
            f"render() {env_id} {r['shape'][1]}×{r['shape'][0]}: {r['ms_wall']:.1f} ms wall, "
            f"{r['ms_cpu']:.1f} ms CPU per frame"
        )
    sb3 = results.get("sac_her")
    if sb3 is not None:
        ms = sb3["ms_per_step"]
        lines.append(
            f"SAC + HER {ms['sac_her']:.2f} ms vs SAC {ms['sac']:.2f} ms CPU per env step "
            f"({sb3['env']}): ×{sb3['ratio']:.2f}"
        )
    return "\n".join(lines)


def measure_agents(steps: int, sb3_steps: int, sb3_rounds: int, seed: int) -> dict:
    return {
        "pixels": time_pixel_steps(steps, seed),
        "render": time_render(RENDER_FRAMES, seed),
        "sac_her": time_sac_her(sb3_steps, sb3_rounds, seed),
    }
