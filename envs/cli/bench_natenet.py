"""Query time of NATEnet beside the exact inverse Jacobian, measured in the same run.

    .venv/bin/python scripts/bench_natenet.py                          # a 60-node net, 2000 queries
    .venv/bin/python scripts/bench_natenet.py --net runs/natenet/natenet.npz

NATEnet: ``net.predict(θ)`` (θ1..θ5 for a 5-input net). Exact: ``np.linalg.solve(jacobian(θ), I)``
with ``models.puma560.kinematics.jacobian``. Both are timed one query at a time (what a controller
does every step) and vectorised over all queries; the best of ``--repeats`` runs is kept. Without
``--net`` the net is built by allocating ``--nodes`` nodes at configurations of random paths with
exact targets (the query cost depends only on the node count). Writes ``bench.json`` to ``--out``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from learners.natenet import NATEnet
from models.paths import sample_path
from models.puma560.kinematics import jacobian

INPUT_DIM = 5  # θ6 does not change the base-frame Jacobian


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = cli.parser(__doc__)
    ap.add_argument("--net", type=Path, default=None, help="a saved NATEnet (.npz)")
    cli.add_count(ap, "--nodes", 60, "node count of the built net")
    ap.add_argument("--queries", type=cli.positive_int, default=2000)
    ap.add_argument("--repeats", type=cli.positive_int, default=3)
    options.SEED.add(ap)
    options.OUT.add(ap, default=Path("runs/bench_natenet"))
    return ap.parse_args(argv)


def build_net(configs: np.ndarray, nodes: int) -> NATEnet:
    """A net holding the exact inverse Jacobian at the first ``nodes`` configurations."""
    net = NATEnet(input_dim=INPUT_DIM, T0=0.0, e_f=0.0, T_a=1.0, max_nodes=nodes)
    for theta in configs[:nodes]:
        net.learn(theta[:INPUT_DIM], np.linalg.inv(jacobian(theta)).T, np.eye(6))
    return net


def best_time(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    rng = np.random.default_rng(args.seed)
    configs = np.concatenate(
        [
            sample_path(rng, "circle").joints
            for _ in range(max(1, (args.queries + args.nodes) // 100 + 1))
        ]
    )
    rng.shuffle(configs)
    net = NATEnet.load(args.net) if args.net else build_net(configs[args.queries :], args.nodes)
    queries = configs[: args.queries]
    x = queries[:, : net.input_dim]
    eye = np.eye(6)

    def net_single():
        for q in x:
            net.predict(q)

    def exact_single():
        for q in queries:
            np.linalg.solve(jacobian(q), eye)

    n = len(queries)
    rows = {
        "single": (
            best_time(net_single, args.repeats) / n,
            best_time(exact_single, args.repeats) / n,
        ),
        "batch": (
            best_time(lambda: net.predict(x), args.repeats) / n,
            best_time(lambda: np.linalg.solve(jacobian(queries), eye), args.repeats) / n,
        ),
    }
    result = {
        "nodes": net.n_nodes,
        "input_dim": net.input_dim,
        "queries": n,
        "source": str(args.net) if args.net else "built",
    }
    print(f"NATEnet with {net.n_nodes} nodes, {n} queries (best of {args.repeats})")
    print(f"{'mode':>8} {'NATEnet µs':>12} {'exact µs':>10} {'exact/NATEnet':>14}")
    for mode, (t_net, t_exact) in rows.items():
        result[mode] = {
            "natenet_us": t_net * 1e6,
            "exact_us": t_exact * 1e6,
            "ratio_exact_over_natenet": t_exact / t_net,
        }
        print(f"{mode:>8} {t_net * 1e6:12.2f} {t_exact * 1e6:10.2f} {t_exact / t_net:14.2f}")
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "bench.json", result)
    return result


#: Console entry point ``visuomotor-bench-natenet``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
