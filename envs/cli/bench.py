"""Benchmarks that print numbers and ratios against a peer measured in the same run.

    .venv/bin/python scripts/bench.py envs      # env steps/s vs Gymnasium's Reacher-v5
    .venv/bin/python scripts/bench.py som       # SOM trials/s vs MiniSom's winner + update
    .venv/bin/python scripts/bench.py ik        # AnalyticIK / JacobianIK / SOM act_batch
    .venv/bin/python scripts/bench.py natenet   # NATEnet query vs exact inverse Jacobian
    .venv/bin/python scripts/bench.py trials    # a realistic training trial's renders, steps, ms
    .venv/bin/python scripts/bench.py all       # each of them with its own defaults

Options after the name go to that benchmark (see e.g. ``bench.py som --help``); ``all`` takes
none, since the benchmarks have different options.
"""

from __future__ import annotations

import argparse
import importlib

from envs.cli import common as cli

BENCHMARKS = ("envs", "som", "ik", "natenet", "trials")


def main(argv: list[str] | None = None) -> None:
    p = cli.parser(__doc__)
    p.add_argument("benchmark", choices=(*BENCHMARKS, "all"), help="which benchmark to run")
    p.add_argument("options", nargs=argparse.REMAINDER, help="options of that benchmark")
    args = p.parse_args(argv)
    if args.benchmark == "all" and args.options:
        p.error(f"'all' runs each benchmark with its defaults; give {args.options} to one of them")
    names = BENCHMARKS if args.benchmark == "all" else (args.benchmark,)
    for name in names:
        print(f"\n== bench {name} ==")
        importlib.import_module(f"envs.cli.bench_{name}").main(args.options)


#: Console entry point ``visuomotor-bench``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
