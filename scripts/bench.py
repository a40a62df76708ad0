"""Benchmarks that print numbers and ratios against a peer measured in the same run.

python scripts/bench.py envs      # env steps/s vs Gymnasium's Reacher-v5
python scripts/bench.py som       # SOM trials/s vs MiniSom's winner + update
python scripts/bench.py ik        # AnalyticIK / JacobianIK / SOM act_batch
python scripts/bench.py natenet   # NATEnet query vs exact inverse Jacobian
python scripts/bench.py all
"""

from __future__ import annotations

import importlib
import sys

BENCHMARKS = ("envs", "som", "ik", "natenet")


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] not in (*BENCHMARKS, "all"):
        raise SystemExit(f"usage: bench.py {{{','.join(BENCHMARKS)},all}} [options]")
    names = BENCHMARKS if argv[0] == "all" else (argv[0],)
    for name in names:
        print(f"\n== bench {name} ==")
        importlib.import_module(f"bench_{name}").main(argv[1:])


if __name__ == "__main__":
    main()
