"""Speed of the visuomotor SOM, with MiniSom measured in the same run as the peer.

Rows of the table:
  * full trials/s: ``act(u)`` + ``act(u, v0, explore=True)`` + ``learn(u, θ0, v0, θ1, v1)`` over
    one whole training schedule (t = 0 .. t_max, so wide and narrow neighbourhoods both count),
    and over trials after t_max (the narrowest neighbourhood), inputs precomputed, no env; for
    each kernel (numba when installed, and the numpy reference);
  * MiniSom winner + update/s on a 2-D lattice with the same number of neurons and 4-D inputs.
    Map and peer take turns on blocks of ``--block`` trials, so a change in the load of the
    shared machine hits both; a round's ratio is the median over its blocks of peer time / map
    time. ``--rounds`` rounds, each with a new map and a new MiniSom over the same inputs; the
    ratio printed is the median over the rounds, with the lowest and highest round beside it;
  * act_batch targets/s: coarse commands for a block of targets at once;
  * a large lattice (``--big``, default 40×40×40): construction time, memory held (peak of
    numpy allocations while constructing and training, from tracemalloc) and trials/s;
  * the evaluation's fine move: µs of the first ``act(u, v)`` after a coarse move of the
    trained map (``abar="local-fit"``: it fits Ā), per kernel, beside the whole command of
    ``AnalyticIK`` (triangulation and closed-form IK of the RIACS arm) as the peer, taking turns
    block by block; medians over the calls.
Writes ``bench_som.json``.

    .venv/bin/python scripts/bench_som.py [--trials 10000] [--big 40 40 40] [--out runs/bench_som]
"""

from __future__ import annotations

from pathlib import Path

from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from envs.studies.map_speed import benchmark


def main(argv: list[str] | None = None) -> dict:
    parser = cli.parser(__doc__)
    options.TRIALS.add(parser, default=10_000, help="trials = t_max of the run")
    cli.add_count(parser, "--block", 100, "trials per turn of map and peer")
    cli.add_count(parser, "--rounds", 5, "new map and peer, same inputs")
    cli.add_count(parser, "--batch", 10_000, "targets per act_batch call")
    options.LATTICE.add(parser, default="12x7x4")
    parser.add_argument(
        "--big", type=cli.lattice_or_none, default="40x40x40", help="none: skip (default: 40x40x40)"
    )
    cli.add_count(parser, "--big-trials", 2000, "t_max of the big lattice")
    options.SEED.add(parser)
    options.OUT.add(parser, default=Path("runs/bench_som"))
    args = parser.parse_args(argv)
    result = benchmark(
        args.lattice, args.trials, args.block, args.rounds, args.batch, args.big,
        args.big_trials, args.seed,
    )  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "bench_som.json", result)
    return result


#: Console entry point ``visuomotor-bench-som``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
