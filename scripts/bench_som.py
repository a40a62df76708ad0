"""Speed of the visuomotor SOM, with MiniSom measured in the same run as the peer.

Rows of the table:
  * full trials/s: ``act(u)`` + ``act(u, v0, explore=True)`` + ``learn(u, θ0, v0, θ1, v1)`` over
    one whole training schedule (t = 0 .. t_max, so wide and narrow neighbourhoods both count),
    and over trials after t_max (the narrowest neighbourhood), inputs precomputed, no env;
  * act_batch targets/s: coarse commands for a block of targets at once;
  * MiniSom winner + update/s on a 2-D lattice with the same number of neurons and 4-D inputs.
Each figure is the best of ``--repeats`` runs (the machine is shared). Writes ``bench_som.json``.

    python scripts/bench_som.py [--trials 10000] [--out runs/bench_som]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from learners.som import VisuomotorSOM
from models.riacs import LOWER, UPPER

IMAGE_SIZE = np.array([320.0, 240.0, 320.0, 240.0])  #: input box of the random pixels (px)
COARSE_ERROR_PX = 5.0  #: std of the simulated sensed position after the coarse move (px)
FINE_ERROR_PX = 1.0  #: ... and after the fine move (px)
MINISOM_SHAPE = (21, 16)  #: 336 neurons, as the default 12 × 7 × 4 lattice


def _inputs(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    U = rng.uniform(0.0, IMAGE_SIZE, size=(n, 4))
    return (
        U,
        U + rng.normal(0.0, COARSE_ERROR_PX, size=U.shape),
        U + rng.normal(0.0, FINE_ERROR_PX, size=U.shape),
    )


def _som(lattice: tuple[int, ...], trials: int, seed: int) -> VisuomotorSOM:
    return VisuomotorSOM(
        LOWER, UPPER, lattice=lattice, t_max=trials, rng=seed, input_high=IMAGE_SIZE
    )


def time_trials(som: VisuomotorSOM, U: np.ndarray, V0: np.ndarray, V1: np.ndarray) -> float:
    """Full trials per second on the given inputs."""
    start = time.perf_counter()
    for u, v0, v1 in zip(U, V0, V1, strict=True):
        som.reset()
        theta0 = som.act(u)
        theta1 = som.act(u, v0, explore=True)
        som.learn(u, theta0, v0, theta1, v1)
    return len(U) / (time.perf_counter() - start)


def time_minisom(U: np.ndarray, seed: int) -> float:
    """MiniSom winner + update per second, one pass over U."""
    from minisom import MiniSom

    som = MiniSom(*MINISOM_SHAPE, U.shape[1], sigma=2.0, learning_rate=1.0, random_seed=seed)
    som.random_weights_init(U[:1000])
    start = time.perf_counter()
    for t, u in enumerate(U):
        som.update(u, som.winner(u), t, len(U))
    return len(U) / (time.perf_counter() - start)


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trials", type=int, default=10_000, help="trials = t_max of the run")
    parser.add_argument("--batch", type=int, default=10_000, help="targets per act_batch call")
    parser.add_argument("--lattice", type=int, nargs="+", default=[12, 7, 4])
    parser.add_argument("--repeats", type=int, default=3, help="best of this many runs")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("runs/bench_som"))
    args = parser.parse_args(argv)
    lattice = tuple(args.lattice)
    U, V0, V1 = _inputs(np.random.default_rng(args.seed), args.trials)
    schedule, late, batch, peer = [], [], [], []
    for _ in range(args.repeats):
        som = _som(lattice, args.trials, args.seed)
        schedule.append(time_trials(som, U, V0, V1))  # t = 0 .. t_max
        late.append(time_trials(som, U, V0, V1))  # t > t_max: winner-only updates
        start = time.perf_counter()
        som.act_batch(np.resize(U, (args.batch, 4)))
        batch.append(args.batch / (time.perf_counter() - start))
        peer.append(time_minisom(U, args.seed))
    n = int(np.prod(lattice))
    result = {
        "neurons": n,
        "trials": args.trials,
        "full_trials_per_s": max(schedule),
        "full_trials_per_s_after_t_max": max(late),
        "act_batch_targets_per_s": max(batch),
        "minisom_updates_per_s": max(peer),
        "ratio_full_trial_to_minisom_update": max(schedule) / max(peer),
    }
    rows = [
        (
            f"VisuomotorSOM {'x'.join(map(str, lattice))} full trial, t = 0..t_max",
            "trials/s",
            result["full_trials_per_s"],
        ),
        (
            "VisuomotorSOM full trial, t > t_max",
            "trials/s",
            result["full_trials_per_s_after_t_max"],
        ),
        (
            f"VisuomotorSOM act_batch ({args.batch} targets)",
            "targets/s",
            result["act_batch_targets_per_s"],
        ),
        (
            f"MiniSom {MINISOM_SHAPE[0]}x{MINISOM_SHAPE[1]} winner + update",
            "updates/s",
            result["minisom_updates_per_s"],
        ),
    ]
    print(f"{'what (' + str(n) + ' neurons, 4-D input)':<52} {'unit':>10} {'rate':>12}")
    for what, unit, rate in rows:
        print(f"{what:<52} {unit:>10} {rate:>12,.0f}")
    print(f"ratio full trial / MiniSom update: {result['ratio_full_trial_to_minisom_update']:.2f}")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_som.json").write_text(json.dumps(result, indent=2) + "\n")
    return result


if __name__ == "__main__":
    main()
