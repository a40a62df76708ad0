"""Evaluate controllers on fresh held-out targets: a table of errors after each move, and plots.

    .venv/bin/python scripts/evaluate.py --run runs/riacs          # the trained SOM of a run
    .venv/bin/python scripts/evaluate.py --run runs/riacs --compare analytic jacobian
    .venv/bin/python scripts/evaluate.py --env PumaReach-v0 --controller analytic
    .venv/bin/python scripts/evaluate.py --run runs/grasp --compare pose_ik   # the grasp task

On PumaGrasp-v0 the table gives, after every move, the position error (mm and % of the robot's
reach) and the orientation error (degrees); the floor is the exact pose IK (pose_ik) through
the same cameras. No plots there.

Plots (for the first controller, if it is a SOM): learning curve (from the run's
metrics.jsonl), error histogram, lattice in the left camera's image, targets and reached
positions in 3-D, error map over the workspace. Numbers go to OUT/evaluation.json.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options
from envs.cli.controllers import (
    POSE_SPECS,
    SPECS,
    check_task,
    controller_spec,
    make_controller,
    run_folder,
)
from envs.grasp import GRASP_ENV_IDS
from envs.harness.checkpoint import checkpoint_path, read_identity
from envs.harness.evaluation import Evaluation, Ticking, evaluate
from envs.harness.run_folder import check_writable, read_metrics, write_json
from envs.harness.streams import seed_env
from envs.harness.training import METRICS_FILE, RunConfig, Trainer
from envs.reach import IMAGE_HEIGHT, IMAGE_WIDTH
from envs.sizes import format_size
from envs.studies.evaluation_report import format_pose_table, format_table, som_name, write_plots
from learners.som.controller import VisuomotorSOM
from learners.som.hierarchical import HierarchicalSOM


def main(argv: list[str] | None = None) -> dict:
    p = cli.parser(__doc__)
    p.add_argument(
        "--run",
        type=run_folder,
        help="a train.py run folder (checkpoint.npz, metrics.jsonl) or its checkpoint.npz",
    )
    options.CONTROLLER.add(p, help=f"instead of --run: {SPECS}; on PumaGrasp-v0: {POSE_SPECS}")
    p.add_argument(
        "--compare",
        nargs="*",
        type=controller_spec,
        default=[],
        help="more controllers, as --controller",
    )
    options.ENV.add(p, help="default: the run's env")
    options.SENSING.add(p, note=f"default: the run's, without a run {RunConfig.sensing}")
    options.CONTROL.add(p, note=f"default: the run's, without a run {RunConfig.control}")
    options.IMAGE_SIZE.add(p, help="sensing images WIDTHxHEIGHT (default: the run's)")
    options.ORIENTATIONS.add(p, note="default: the run's, else the env's")
    options.TARGETS.add(p)
    options.FINE_MOVES.add(p)
    options.EVALUATION_SET.add(p)
    options.OUT.add(p, help="default: RUN/eval or runs/eval")
    p.add_argument("--no-plots", action="store_true")
    options.PROTOCOL.add(p, help="how a SOM moves (default: the protocol it was trained with)")
    p.add_argument(
        "--no-refine",
        action="store_true",
        help="SOM fine moves as MRS publish them: the averaged Ā, no Broyden step",
    )
    p.add_argument(
        "--no-backtrack",
        action="store_true",
        help="PumaGrasp-v0: the hierarchical map's fine moves never return to the best pose "
        "seen (as in the papers)",
    )
    p.add_argument(
        "--trust-radius",
        type=cli.nonnegative_float,
        help="PumaGrasp-v0: the hierarchical map's fine-move trust radius, rad (default: the "
        "map's; 0: the first releases' halving backtrack)",
    )
    options.ABAR_OPTION.add(
        p, help="Ā of a SOM's fine moves (default: the map's; --no-refine: average)"
    )
    p.add_argument(
        "--recover",
        action="store_true",
        help="a SOM recovers when a camera loses the marker (detour moves, counted) instead "
        "of stopping the trial as MRS's loop does",
    )
    args = p.parse_args(argv)
    if (args.run is None) == (args.controller is None):
        p.error("give either --run DIR or --controller SPEC")

    run_config = {}
    if args.run is not None:
        checkpoint = checkpoint_path(args.run)
        if read_identity(checkpoint) is None:
            cli.fail(
                f"{checkpoint} is a map without a training run's state; evaluate it with "
                f"--controller {checkpoint}"
            )
        run_config = vars(Trainer.stored_config(args.run))
    env_id = args.env or run_config.get("env", RunConfig.env)
    sensing = args.sensing or run_config.get("sensing", RunConfig.sensing)
    control = args.control or run_config.get("control", RunConfig.control)
    width, height = args.image_size or (
        run_config.get("width", IMAGE_WIDTH),
        run_config.get("height", IMAGE_HEIGHT),
    )
    cli.check_image_size(env_id, (width, height))
    if args.targets * (args.fine_moves + 1) > cli.MAX_ERRORS:
        cli.fail(
            f"--targets {args.targets} with --fine-moves {args.fine_moves} keep "
            f"{args.targets * (args.fine_moves + 1):,} errors; at most {cli.MAX_ERRORS:,} "
            "(targets x moves) fit in memory: give fewer"
        )
    out = args.out or (args.run / "eval" if args.run else Path("runs/eval"))
    cli.check_out("--out", out, folder=True)  # --out itself was checked as it was parsed
    specs = [str(checkpoint_path(args.run)) if args.run else args.controller, *args.compare]
    pose = env_id in GRASP_ENV_IDS
    check_task(specs, pose)
    plotted = not args.no_plots and specs[0].endswith(".npz") and not pose
    metrics = None  # read before any work, so that a damaged log stops nothing half-way
    if plotted and args.run is not None and (args.run / METRICS_FILE).is_file():
        metrics = read_metrics(check_writable(args.run) / METRICS_FILE)  # its learning curve
    orientations = args.orientations or run_config.get("orientations")
    if orientations is not None and not pose:
        cli.fail(f"--orientations is for {', '.join(GRASP_ENV_IDS)}, not {env_id}")
    task = {"orientations": orientations} if orientations is not None else {}
    env = gym.make(env_id, sensing=sensing, control=control, width=width, height=height, **task)
    rows, results = [], {}
    for spec in specs:
        controller = make_controller(spec, env, args.seed)
        name = spec
        if isinstance(controller, VisuomotorSOM):
            if args.no_backtrack or args.trust_radius is not None:
                cli.fail(
                    "--no-backtrack and --trust-radius change the hierarchical map of "
                    "PumaGrasp-v0 only"
                )
            controller = controller.with_config(**som_changes(args))
            name = som_name(controller)
        elif isinstance(controller, HierarchicalSOM):
            if args.protocol or args.abar or args.recover:
                cli.fail(
                    "--protocol, --abar and --recover change the reach map; the hierarchical "
                    "map of PumaGrasp-v0 takes --no-refine and --no-backtrack"
                )
            refine, backtrack = not args.no_refine, not args.no_backtrack
            controller = controller.with_fine_moves(refine, backtrack, args.trust_radius)
            name = "hierarchical som" + " (no refine)" * (not refine)
            name += " (no backtrack)" * (not backtrack)
            if backtrack and args.trust_radius is not None:
                name += f" (trust {args.trust_radius:g} rad)"
        seed_env(env, args.seed, "evaluation")  # the same held-out targets for every one
        result = evaluate_with_bar(env, controller, name, args.targets, args.fine_moves)
        results[name] = result
        rows.append({"controller": name, **result.summary()})
    print(f"{env_id}  sensing={sensing} ({format_size(width, height)})  control={control}  "
          f"{args.targets} held-out targets, evaluation set {args.seed}")  # fmt: skip
    print(format_pose_table(rows) if pose else format_table(rows))
    with cli.removed_if_refused(out):  # a failed write leaves no empty folder
        out.mkdir(parents=True, exist_ok=True)
        if pose:
            spread = env.unwrapped.orientations
            print(f"objects' orientations: {'the joint box' if spread is None else spread.spec()}")
        summary = {"env": env_id, "sensing": sensing, "control": control, "seed": args.seed,
                   "width": width, "height": height,
                   "reach_m": env.unwrapped.reach, "controllers": rows}  # fmt: skip
        write_json(out / "evaluation.json", summary)

        if plotted:
            som = VisuomotorSOM.load(specs[0])
            write_plots(env, som, results[rows[0]["controller"]], metrics, args.run, out)
            print(f"plots in {out}")
    env.close()
    return summary


def evaluate_with_bar(env, controller, name: str, targets: int, fine_moves: int) -> Evaluation:
    """:func:`evaluate` with a progress bar labelled ``evaluate NAME``, removed when done."""
    with cli.progress_bar(targets, f"evaluate {name}", "target") as bar:
        return evaluate(env, Ticking(controller, bar.update), targets, fine_moves)


def som_changes(args: argparse.Namespace) -> dict[str, object]:
    """The map options ``--protocol``, ``--no-refine``, ``--abar`` and ``--recover`` change on a
    loaded map."""
    changes: dict[str, object] = {}
    if args.protocol is not None:
        changes["protocol"] = args.protocol
    if args.no_refine:
        changes["refine"] = False
    abar = args.abar or ("average" if args.no_refine else None)
    if abar is not None:
        changes["abar"] = abar
    if args.recover:
        changes["recover"] = True
    return changes


#: Console entry point ``visuomotor-evaluate``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
