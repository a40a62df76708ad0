"""Training with workers measured in one run (``train.py --workers N``): for N = 1 (the
one-process training), 2 and the machine's cores, trials per second after the first round
(start-up left out), the learned map's held-out mean errors after each move and their ratio to
N = 1's, a worker's time per trial and the learner's own (learning, sending its map) as a share
of it: a cluster of many workers stays limited by its workers while that share is small. The
load average is printed with the figures: other work on the machine slows them.

With --round-sizes it measures instead the held-out errors against the round size (the staleness
of a worker's map, in trials; 0: the one-process training), for each of --seeds, the rounds run
in this process.

    .venv/bin/python scripts/bench_workers.py [--trials 2000] [--workers 1,2,4]
    .venv/bin/python scripts/bench_workers.py --sensing project --control kinematic \\
        --trials 10000 --round-sizes 0,1,16,64,256,1024 --seeds 0,1,2
Writes OUT/bench_workers.json (or OUT/round_sizes.json).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

import envs  # noqa: F401  (registers the envs)
from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from envs.harness.training import RunConfig
from envs.limits import MAX_WORKERS
from envs.studies.workers_speed import benchmark, round_sizes

WORKER_COUNT = cli.count(1, MAX_WORKERS, "processes, each with an env")
ROUND_SIZE = cli.count(0, 10**6, "trials of a round")
SEED = cli.count(0, 2**32 - 1, "a seed")


def _list(kind: Any) -> Any:
    """An argparse type: comma-separated values of ``kind``."""

    def parse(text: str) -> list[int]:
        values = [kind(part) for part in text.split(",")]
        if len(set(values)) != len(values):
            raise argparse.ArgumentTypeError(f"repeats a value: {text!r}")
        return values

    parse.__name__ = "a comma-separated list"
    return parse


def main(argv: list[str] | None = None) -> dict:
    parser = cli.parser(__doc__)
    options.ENV.add(parser, default="RiacsReach-v0")
    options.SENSING.add(parser, default="foveated")
    options.CONTROL.add(parser, default="servo")
    options.TRIALS.add(parser, default=2000, help="training trials of each run")
    options.TARGETS.add(parser, default=1000, help="held-out targets of each map")
    options.FINE_MOVES.add(parser, default=3)
    options.LATTICE.add(parser, default=None, help="lattice shape (default: the map's)")
    cores = os.cpu_count() or 1
    parser.add_argument("--workers", type=_list(WORKER_COUNT), default=None,
                        help=f"numbers of workers (default 1,2,{cores}: the cores)")  # fmt: skip
    parser.add_argument("--round-sizes", type=_list(ROUND_SIZE), default=None,
                        help="measure the held-out errors against these round sizes "
                        "instead")  # fmt: skip
    parser.add_argument("--seeds", type=_list(SEED), default=[0], help="seeds of --round-sizes")
    options.SEED.add(parser)
    options.OUT.add(parser, default=Path("runs/bench_workers"))
    args = parser.parse_args(argv)
    settings = {} if args.lattice is None else {"lattice": args.lattice}
    config = RunConfig.of(
        env=args.env, sensing=args.sensing, control=args.control, trials=args.trials,
        seed=args.seed, eval_every=args.trials, eval_trials=1, fine_moves=args.fine_moves,
        **settings,
    )  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    if args.round_sizes is not None:
        result = round_sizes(config, args.round_sizes, args.seeds, args.targets)
        _print_round_sizes(result)
        write_json(args.out / "round_sizes.json", result)
        return result
    counts = args.workers or sorted({1, 2, cores})
    result = benchmark(config, counts, args.targets)
    _print_benchmark(result, args)
    write_json(args.out / "bench_workers.json", result)
    return result


def _moves(values: list[float], digits: int) -> str:
    return " / ".join(f"{v:.{digits}f}" for v in values)


def _print_benchmark(result: dict, args: argparse.Namespace) -> None:
    print(
        f"{args.env}, {args.sensing} sensing, {args.control} control, {args.trials} trials per "
        f"run, {args.targets} held-out targets; {result['cores']} cores, load average "
        f"{result['load_average_before']} before, {result['load_average_after']} after"
    )
    print("workers  trials/s  held-out mean mm (coarse / fine 1..)  ratio to N=1  "
          "worker ms/trial  learner ms/trial  learner share")  # fmt: skip
    for row in result["rows"]:
        tail = ""
        if "worker_ms_per_trial" in row:
            tail = (f"  {row['worker_ms_per_trial']:15.2f}  {row['learner_ms_per_trial']:16.3f}"
                    f"  {row['learner_share_percent']:12.2f} %")  # fmt: skip
        errors, ratios = _moves(row["held_out_mm"], 2), _moves(row["held_out_ratio"], 3)
        print(f"{row['workers']:7d}  {row['trials_per_s']:8.1f}  {errors:36s}  {ratios}{tail}")


def _print_round_sizes(result: dict) -> None:
    print(f"held-out mean errors (mm, coarse / fine 1..) over seeds {result['seeds']}, "
          f"{result['targets']} targets each; round 0: the one-process training")  # fmt: skip
    for row in result["rows"]:
        print(f"round {row['round_trials']:6d}: {_moves(row['mean_mm'], 3)}")


#: Console entry point ``visuomotor-bench-workers``.
run = cli.entry_point(main)
