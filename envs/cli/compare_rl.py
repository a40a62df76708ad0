"""The visuomotor map against SB3's SAC + HER, SAC and PPO: learning curves on held-out targets.

    .venv/bin/python scripts/compare_rl.py --env RiacsReach-v0 PumaReach-v0 --sensing project \\
        --control kinematic --budget 10000 --checkpoints 6 --seeds 0 1 2 --out runs/compare_rl/pk
    .venv/bin/python scripts/compare_rl.py --env RiacsReach-v0 --sensing render --control servo \\
        --budget 1000 --checkpoints 2 --targets 200 --seeds 0 --out runs/compare_rl/rs

Needs the ``rl`` extra (``pip install -e ".[rl]"``). Writes OUT/curves.jsonl (one line per
method and seed, appended as each finishes; runs split over several invocations with the same
OUT add up), and from all of it OUT/table.md and OUT/<env>_<sensing>_<control>.png.
``--report-only`` rewrites the table and plots from OUT/curves.jsonl without training (no extra
needed): ``scripts/compare_rl.py --report-only --out docs/compare_rl/project_kinematic``.
"""

from __future__ import annotations

import json
from pathlib import Path

import envs  # noqa: F401  (GL back-end, registration)
from envs.cli import common as cli
from envs.reach import REACH_ENV_IDS
from envs.studies import rl_report
from envs.studies.rl_comparison import METHODS, Curve, checkpoints, run_method

TORCH_THREADS = 1  # the machine is shared: one core per run


def import_torch_first():
    """torch, imported before anything renders (so after parsing: ``--help`` needs no torch).

    Mesa's llvmpipe (EGL/OSMesa) loads its LLVM when the first frame is drawn, and triton (which
    torch imports) bundles another LLVM; building a model after a render then segfaults in LLVM's
    global state. Importing torch (and torch._dynamo, which loads triton) first makes triton's
    LLVM the one that initialises. ``import envs`` loads no GL, so this is early enough.
    """
    try:
        import torch
        import torch._dynamo
    except ImportError as exc:
        raise SystemExit(f"compare_rl needs the rl extra ({exc}); pip install -e '.[rl]'") from exc
    return torch


def main(argv: list[str] | None = None) -> list[Curve]:
    p = cli.parser(__doc__)
    p.add_argument("--env", nargs="+", choices=REACH_ENV_IDS, default=list(REACH_ENV_IDS))
    p.add_argument("--sensing", choices=("project", "render"), default="project")
    p.add_argument("--control", choices=("kinematic", "servo"), default="kinematic")
    p.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    p.add_argument("--seeds", nargs="+", type=cli.nonnegative_int, default=[0, 1, 2])
    p.add_argument(
        "--budget", type=cli.positive_int, default=10_000, help="env steps per method and seed"
    )
    p.add_argument(
        "--checkpoints", type=cli.positive_int, default=6, help="evaluations, log-spaced"
    )
    p.add_argument(
        "--targets", type=cli.positive_int, default=1000, help="held-out targets per evaluation"
    )
    p.add_argument("--out", type=Path, default=Path("runs/compare_rl"))
    p.add_argument(
        "--report-only", action="store_true", help="table and plots from OUT/curves.jsonl only"
    )
    args = p.parse_args(argv)
    if args.report_only:
        if not (args.out / "curves.jsonl").is_file():
            raise SystemExit(f"--report-only: {args.out / 'curves.jsonl'} does not exist")
        print(rl_report.report(args.out, args.targets))
        return []
    import_torch_first().set_num_threads(TORCH_THREADS)
    args.out.mkdir(parents=True, exist_ok=True)
    points = checkpoints(args.budget, args.checkpoints)
    setting = {"sensing": args.sensing, "control": args.control}
    curves = []
    for env_id in args.env:
        for method in args.methods:
            for seed in args.seeds:
                curve = run_method(
                    method,
                    env_id=env_id,
                    env_kwargs=setting,
                    seed=seed,
                    budget=args.budget,
                    points=points,
                    targets=args.targets,
                )
                curves.append(curve)
                with open(args.out / "curves.jsonl", "a") as f:
                    f.write(json.dumps({"env": env_id, **setting, **curve.to_json()}) + "\n")
                print(
                    f"{env_id} {method} seed {seed}: {curve.mean_m[-1] * 1e3:.2f} mm mean final "
                    f"distance after {curve.steps[-1]} env steps",
                    flush=True,
                )
    print(rl_report.report(args.out, args.targets))
    return curves


def run() -> None:
    """Console entry point ``visuomotor-compare-rl``."""
    cli.run(main)


if __name__ == "__main__":
    run()
