"""The visuomotor map against SB3's SAC + HER, SAC and PPO: learning curves on held-out targets.

    .venv/bin/python scripts/compare_rl.py --env RiacsReach-v0 PumaReach-v0 --sensing project \\
        --control kinematic --budget 10000 --checkpoints 6 --seeds 0 1 2 --out runs/compare_rl/pk
    .venv/bin/python scripts/compare_rl.py --env RiacsReach-v0 --sensing render --control servo \\
        --budget 1000 --checkpoints 2 --targets 200 --seeds 0 --out runs/compare_rl/rs

Needs the ``rl`` extra (``pip install -e ".[rl]"``). Every (env, method, variant, episode
length, seed) is a run with its own folder OUT/runs/<env>_<sensing>_<control>/<method>-<variant>-
<n>move/seed<k>/ (``envs.studies.rl_runs``): its curve is saved after every checkpoint, SB3 models
with their replay buffers too, so running the same command again skips the finished runs and
continues an interrupted one (two processes with the same command share the runs out). From all
finished runs (and an older OUT/curves.jsonl) it writes OUT/table.md and one plot per env and
setting, OUT/<env>_<sensing>_<control>.png. ``--report-only`` rewrites them without training (no
extra needed): ``scripts/compare_rl.py --report-only --out docs/compare_rl/project_kinematic``.
"""

from __future__ import annotations

from pathlib import Path

import envs  # noqa: F401  (GL back-end, registration)
from envs.cli import common as cli
from envs.cli import options
from envs.harness.training import RunConfig
from envs.reach import MAX_EPISODE_STEPS
from envs.robots import default_reach_env_ids
from envs.studies import rl_report, rl_runs
from envs.studies.rl_comparison import METHODS, VARIANTS, Curve, checkpoints

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
        cli.fail(f"compare_rl needs the rl extra ({exc}); pip install -e '.[rl]'")
    return torch


def main(argv: list[str] | None = None) -> list[Curve]:
    p = cli.parser(__doc__)
    options.ENV.add(p, nargs="+", default=list(default_reach_env_ids()), help="the env ids")
    options.SENSING.add(
        p,
        default=RunConfig.sensing,
        choices=options.WHOLE_IMAGE_SENSING,
        note=options.run_setting_note("sensing"),
    )
    options.CONTROL.add(p, default=RunConfig.control, note=options.run_setting_note("control"))
    p.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    p.add_argument("--seeds", nargs="+", type=cli.seed, default=[0, 1, 2])
    cli.add_count(p, "--budget", 10_000, "env steps per method and seed")
    cli.add_count(p, "--checkpoints", 6, "evaluations, log-spaced")
    options.TARGETS.add(p, help="held-out targets per evaluation")
    p.add_argument(
        "--variants",
        nargs="+",
        choices=VARIANTS,
        default=["zoo"],
        help="settings of the SB3 methods: zoo (RL Zoo's), g2 (2 gradient steps per env step), "
        "gamma0.5, gamma0 (no bootstrapping: for one-move episodes); each method runs those that "
        "apply to it",
    )
    p.add_argument(
        "--episode-steps",
        nargs="+",
        type=cli.positive_int,
        default=[MAX_EPISODE_STEPS],
        help="moves per episode (1: one absolute move per target)",
    )
    for flag, what in (  # lists of env steps
        ("--also-at", "further checkpoints (env steps) beside the log-spaced ones"),
        ("--table-at", "tabulate at these env steps too (the checkpoint at or below each), "
         "beside the end"),
    ):  # fmt: skip
        p.add_argument(flag, nargs="*", type=cli.positive_int, default=[], help=what)
    options.OUT.add(p, default=Path("runs/compare_rl"))
    p.add_argument("--report-only", action="store_true", help="table and plots only, no runs")
    args = p.parse_args(argv)
    if args.report_only:
        if not rl_report.has_runs(args.out):
            cli.fail(f"--report-only: no finished runs or curves.jsonl in {args.out}")
        print(rl_report.report(args.out, args.targets, args.table_at))
        return []
    import_torch_first().set_num_threads(TORCH_THREADS)
    args.out.mkdir(parents=True, exist_ok=True)
    points = sorted(set(checkpoints(args.budget, args.checkpoints)) | set(args.also_at))
    points = [p for p in points if p <= args.budget]
    setting = {"sensing": args.sensing, "control": args.control}
    specs = rl_runs.run_list(
        args.env, setting, args.methods, args.variants, args.episode_steps, args.seeds,
        args.budget, points, args.targets,
    )  # fmt: skip
    curves = []
    for spec in specs:
        curve = rl_runs.run(spec, args.out)
        name = f"{spec.env} {spec.method} {spec.variant} {spec.episode_steps}-move seed {spec.seed}"
        if curve is None:
            print(f"{name}: run by another process, skipped", flush=True)
            continue
        curves.append(curve)
        print(
            f"{name}: {curve.mean_m[-1] * 1e3:.2f} mm mean final distance after "
            f"{curve.steps[-1]} env steps ({curve.train_seconds:.0f} s training)",
            flush=True,
        )
    print(rl_report.report(args.out, args.targets, args.table_at))
    return curves


#: Console entry point ``visuomotor-compare-rl``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
