"""A realistic training trial's cost: renders, views drawn, physics steps and ms per part per
trial (foveated sensing, servo moves, ``train.py``'s trials), the reference path and the
envs' own taking turns in one run, their trials compared bit for bit.

    .venv/bin/python scripts/bench.py trials [--trials 200] [--envs RiacsReach-v0 ...]
        [--block 20] [--settle-speeds 0.002 0.005] [--json runs/bench_trials.json]

Columns per trial: moves (coarse, fine and recovery), renders (read-backs of the sensing
cameras), views drawn in them, foveated windows skipped (they could not show the marker),
physics steps (and per move), then ms: the whole trial, physics (the servo moves with their
settle test), sensing (with its drawing and read-back), the rest (learning, the env's own
arithmetic). Arms: ``plain`` renders every window and tests the settle with numpy; ``default``
is what the envs do.

``--settle-speeds`` also records every physics step of the default path's servo moves and tells,
for each settle speed (beside the envs' own), the steps a move would take and how far the sensed
point still moved between that earlier stop and the move's end.
"""

from __future__ import annotations

from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from envs.studies import trial_cost


def main(argv: list[str] | None = None) -> dict:
    parser = cli.parser(__doc__)
    options.TRIALS.add(parser, default=200, help="training trials per arm and env")
    cli.add_count(parser, "--block", 20, "trials per turn of the two arms")
    parser.add_argument(
        "--envs",
        nargs="+",
        choices=trial_cost.ENV_IDS,
        default=list(trial_cost.ENV_IDS),
        help="the envs measured",
    )
    parser.add_argument(
        "--settle-speeds",
        nargs="+",
        type=cli.positive_float,
        default=None,
        help="also: the steps a move would take with these settle speeds (rad/s)",
    )
    options.SEED.add(parser)
    options.JSON.add(parser)
    args = parser.parse_args(argv)
    results = trial_cost.benchmark(tuple(args.envs), args.trials, args.block, args.seed)
    print(trial_cost.format_table(results))
    if args.settle_speeds is not None:
        speeds = [trial_cost.SETTLE_SPEED, *args.settle_speeds]
        results["settle_speeds"] = [
            trial_cost.settle_speeds(env_id, args.trials, args.seed, speeds) for env_id in args.envs
        ]
        print("\n".join(map(trial_cost.format_settle, results["settle_speeds"])))
    if args.json is not None:
        write_json(args.json, results)
        print(f"wrote {args.json}")
    return results


#: Console entry point ``visuomotor-bench-trials``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
