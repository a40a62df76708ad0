"""Speed of the visuomotor SOM against MiniSom measured in the same run: full training trials
per second over a schedule and after it, coarse commands in batches, a large lattice's
construction, memory and trials per second, and the evaluation's fine move beside
``AnalyticIK``'s command. :func:`benchmark` prints the tables and returns the JSON-ready
numbers; ``scripts/bench_som.py`` (whose help says how each row is measured) is its command
line.
"""

from __future__ import annotations

import math
import time
import tracemalloc

import numpy as np

from envs.sensing.stereo import CameraPair, PinholeCamera
from learners.baselines.analytic_ik import AnalyticIK
from learners.som.controller import VisuomotorSOM, kernels
from models import load_model, riacs
from models.riacs import LOWER, UPPER

IMAGE_SIZE = np.array([320.0, 240.0, 320.0, 240.0])  #: input box of the random pixels (px)
COARSE_ERROR_PX = 5.0  #: std of the simulated sensed position after the coarse move (px)
FINE_ERROR_PX = 1.0  #: ... and after the fine move (px)
MIB = 2**20  #: bytes
PHASES = ("schedule", "after_t_max")


def _inputs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    U = rng.uniform(0.0, IMAGE_SIZE, size=(n, 4))
    return (
        U,
        U + rng.normal(0.0, COARSE_ERROR_PX, size=U.shape),
        U + rng.normal(0.0, FINE_ERROR_PX, size=U.shape),
    )


def _som(lattice: tuple[int, ...], trials: int, seed: int, kernel: str) -> VisuomotorSOM:
    return VisuomotorSOM(
        LOWER, UPPER, lattice=lattice, t_max=trials, rng=seed, input_high=IMAGE_SIZE, kernel=kernel
    )


def minisom_shape(neurons: int) -> tuple[int, int]:
    """The most nearly square 2-D lattice with exactly ``neurons`` neurons (336 -> 21 × 16)."""
    rows = max(r for r in range(1, math.isqrt(neurons) + 1) if neurons % r == 0)
    return neurons // rows, rows


def time_trials(som: VisuomotorSOM, U: np.ndarray, V0: np.ndarray, V1: np.ndarray) -> float:
    """Seconds for full trials on the given inputs."""
    start = time.perf_counter()
    for u, v0, v1 in zip(U, V0, V1, strict=True):
        som.reset()
        theta0 = som.act(u)
        theta1 = som.act(u, v0, explore=True)
        som.learn(u, theta0, v0, theta1, v1)
    return time.perf_counter() - start


class Peer:
    """MiniSom on the same number of neurons, trained over the same inputs (its own schedule)."""

    def __init__(self, neurons: int, U: np.ndarray, seed: int) -> None:
        from minisom import MiniSom

        self.shape = minisom_shape(neurons)
        self.som = MiniSom(*self.shape, U.shape[1], sigma=2.0, learning_rate=1.0, random_seed=seed)
        self.som.random_weights_init(U[:1000])
        self.t, self.t_max = 0, len(U)

    def time(self, U: np.ndarray) -> float:
        """Seconds for winner + update on each row of U."""
        start = time.perf_counter()
        for u in U:
            self.som.update(u, self.som.winner(u), self.t, self.t_max)
            self.t += 1
        return time.perf_counter() - start


def interleaved(som: VisuomotorSOM, peer: Peer, inputs, block: int) -> tuple[float, float, float]:
    """Seconds of the map's trials and of the peer's updates, taking turns block by block, and
    the median over the blocks of the ratio peer seconds / map seconds."""
    ours, theirs = [], []
    for i in range(0, len(inputs[0]), block):
        ours.append(time_trials(som, *(x[i : i + block] for x in inputs)))
        theirs.append(peer.time(inputs[0][i : i + block]))
    return sum(ours), sum(theirs), float(np.median(np.array(theirs) / np.array(ours)))


def rounds(
    kernel: str, lattice: tuple[int, ...], inputs, block: int, count: int, seed: int
) -> dict[str, dict]:
    """Per phase ("schedule": t = 0..t_max, "after_t_max": as many trials again): trials/s of
    the map and updates/s of MiniSom over all ``count`` rounds, and each round's ratio."""
    n, trials = math.prod(lattice), len(inputs[0])
    phases: dict[str, dict] = {p: {"ours": 0.0, "theirs": 0.0, "ratios": []} for p in PHASES}
    for _ in range(count):
        som, peer = _som(lattice, trials, seed, kernel), Peer(n, inputs[0], seed)
        for phase in PHASES:  # the second one continues the same map and peer, t > t_max
            ours, theirs, ratio = interleaved(som, peer, inputs, block)
            phases[phase]["ours"] += ours
            phases[phase]["theirs"] += theirs
            phases[phase]["ratios"].append(ratio)
    return {
        phase: {
            "trials_per_s": count * trials / p["ours"],
            "minisom_updates_per_s": count * trials / p["theirs"],
            "ratio": float(np.median(p["ratios"])),
            "round_ratios": p["ratios"],
        }
        for phase, p in phases.items()
    }


def big_lattice(lattice: tuple[int, ...], trials: int, seed: int, kernel: str) -> dict:
    """Construction seconds, peak MiB of numpy allocations, and trials per second of wall
    time and of this process's CPU time (the machine is shared) over a schedule."""
    inputs = _inputs(np.random.default_rng(seed), trials)
    tracemalloc.start()
    start = time.perf_counter()
    som = _som(lattice, trials, seed, kernel)
    built = time.perf_counter() - start
    cpu = time.process_time()
    seconds = time_trials(som, *inputs)
    cpu = time.process_time() - cpu
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return {
        "construct_s": built,
        "peak_mib": peak / MIB,
        "trials_per_s": trials / seconds,
        "trials_per_cpu_s": trials / cpu,
    }


def analytic_ik(targets: int, seed: int) -> tuple[AnalyticIK, np.ndarray]:
    """The RIACS arm's AnalyticIK behind its scene's two cameras (projection only, no
    renderer), and the pixels (targets, 4) of points drawn from its workspace."""
    import mujoco

    model = load_model("riacs")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rig = CameraPair(
        [PinholeCamera.from_model(model, data, c, 240, 320) for c in ("cam_left", "cam_right")]
    )
    points = riacs.WORKSPACE.sample(np.random.default_rng(seed), targets)
    return AnalyticIK.for_robot(rig.triangulate, "riacs"), rig.project(points)


def fine_move_seconds(som: VisuomotorSOM, U: np.ndarray, V: np.ndarray) -> list[float]:
    """Seconds of each evaluation fine move: ``act(u, v)`` right after ``reset`` and ``act(u)``
    (not timed), without exploration, as the evaluation makes it."""
    seconds = []
    for u, v in zip(U, V, strict=True):
        som.reset()
        som.act(u)
        start = time.perf_counter()
        som.act(u, v)
        seconds.append(time.perf_counter() - start)
    return seconds


def command_seconds(peer: AnalyticIK, U: np.ndarray) -> list[float]:
    """Seconds of each whole ``act(u)`` of the peer."""
    seconds = []
    for u in U:
        start = time.perf_counter()
        peer.act(u)
        seconds.append(time.perf_counter() - start)
    return seconds


def fine_moves(maps: dict[str, VisuomotorSOM], inputs, block: int, seed: int) -> dict[str, float]:
    """Median µs of a trained map's evaluation fine move per kernel and of AnalyticIK's
    command, measured in turns block by block over the same number of calls."""
    U, V = inputs[0], inputs[1]
    peer, peer_U = analytic_ik(len(U), seed)
    command_seconds(peer, peer_U[:block])  # first calls out of the way
    for som in maps.values():
        fine_move_seconds(som, U[:block], V[:block])
    seconds: dict[str, list[float]] = {name: [] for name in (*maps, "AnalyticIK")}
    for i in range(0, len(U), block):
        for name, som in maps.items():
            seconds[name] += fine_move_seconds(som, U[i : i + block], V[i : i + block])
        seconds["AnalyticIK"] += command_seconds(peer, peer_U[i : i + block])
    return {name: 1e6 * float(np.median(s)) for name, s in seconds.items()}


def benchmark(
    lattice: tuple[int, ...],
    trials: int,
    block: int,
    n_rounds: int,
    batch: int,
    big: tuple[int, ...] | None,
    big_trials: int,
    seed: int,
) -> dict:
    """Every row of the benchmark, printed as it is measured; returns the JSON-ready numbers.

    Args:
        lattice: the map's lattice; ``trials`` its t_max and the trials timed per phase.
        block: trials per turn of map and peer; ``n_rounds`` rounds of new maps and peers.
        batch: targets per ``act_batch`` call.
        big: the large lattice (None: left out), trained ``big_trials`` trials.
    """
    n = math.prod(lattice)
    inputs = _inputs(np.random.default_rng(seed), trials)
    result: dict = {"neurons": n, "trials": trials, "minisom_shape": minisom_shape(n)}
    rows, trained = [], {}
    for kernel in ("numba", "numpy") if kernels.available() else ("numpy",):
        time_trials(_som(lattice, 3, seed, kernel), *(x[:3] for x in inputs))  # compiles
        measured = rounds(kernel, lattice, inputs, block, n_rounds, seed)
        for phase, figures in measured.items():
            result[f"{kernel}_{phase}"] = figures
            when = "t = 0..t_max" if phase == "schedule" else "t > t_max"
            rows.append((f"{kernel}: full trial, {when}", figures["trials_per_s"], figures))
        som = _som(lattice, trials, seed, kernel)
        time_trials(som, *inputs)
        trained[kernel] = som
        U = np.resize(inputs[0], (batch, 4))
        start = time.perf_counter()
        som.act_batch(U)
        rows.append((f"{kernel}: act_batch targets", batch / (time.perf_counter() - start), None))
    peer_shape = "x".join(map(str, result["minisom_shape"]))
    print(f"{n} neurons ({'x'.join(map(str, lattice))}), 4-D input; peer: MiniSom {peer_shape} "
          f"winner + update, same run, same blocks; {n_rounds} rounds of {trials} "
          "trials per phase")  # fmt: skip
    print(f"{'what':<40} {'per s':>10} {'/ MiniSom (median of rounds)':>29} {'rounds':>12}")
    for what, rate, figures in rows:
        ratio, spread = "", ""
        if figures is not None:
            low, high = min(figures["round_ratios"]), max(figures["round_ratios"])
            ratio, spread = f"{figures['ratio']:.2f}", f"{low:.2f}-{high:.2f}"
        print(f"{what:<40} {rate:>10,.0f} {ratio:>29} {spread:>12}")
    fine = fine_moves(trained, inputs, block, seed)
    result["fine_move_us"] = fine
    print(f"\nevaluation fine move of the trained map (abar={trained['numpy'].abar}, first "
          f"act(u, v) after act(u)) beside AnalyticIK's command (RIACS), same run, same blocks; "
          f"medians of {trials} calls")  # fmt: skip
    print(f"{'what':<40} {'µs/call':>10} {'/ AnalyticIK':>13}")
    for name, micros in fine.items():
        what = "AnalyticIK: command" if name == "AnalyticIK" else f"{name}: map fine move"
        print(f"{what:<40} {micros:>10.1f} {micros / fine['AnalyticIK']:>13.2f}")
    if big:
        for kernel in ("numba", "numpy") if kernels.available() else ("numpy",):
            figures = big_lattice(big, big_trials, seed, kernel)
            result[f"big_{kernel}"] = {"lattice": list(big), **figures}
            print(f"{kernel}: {'x'.join(map(str, big))} = {math.prod(big):,} neurons: constructs "
                  f"in {figures['construct_s']:.3f} s, holds {figures['peak_mib']:.0f} MiB, "
                  f"{figures['trials_per_s']:,.0f} trials/s ({figures['trials_per_cpu_s']:,.0f} "
                  f"per CPU-s), t = 0..{big_trials}")  # fmt: skip
    return result
