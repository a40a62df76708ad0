"""Train the visuomotor SOM on a reach env, headless, with checkpoints and held-out evaluations.

    .venv/bin/python scripts/train.py --env RiacsReach-v0 --trials 10000 --out runs/riacs
    .venv/bin/python scripts/train.py --out runs/riacs --resume   # continue a stopped run
    .venv/bin/python scripts/train.py --env PumaGrasp-v0 --trials 6144 --out runs/grasp

On PumaGrasp-v0 (the hand's position and orientation) it trains the hierarchical map: --lattice
is its position lattice (default 8x8x6) and --orientation-lattice the lattice nested at every
position node (default 2x2x2); --rule, --protocol and --abar belong to the reach map only. The
held-out evaluations then also give the orientation error in degrees.

Writes OUT/checkpoint.npz (the checkpoint: the map, where the run stands, the simulation state; it
loads as a map) and OUT/metrics.jsonl (a held-out evaluation every --eval-every trials: errors
after the coarse move and each fine move in mm, % of the robot's reach and pixels).

Ctrl-C or SIGTERM finishes the current trial, saves and exits (130 or 143); --resume then
continues exactly as if the run had never stopped, also after a kill or a power cut. One
process at a time may write to OUT; a fresh run refuses a folder that holds a run unless
--force. On --resume only --trials (to extend the run) and --checkpoint-every may change.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import fields
from pathlib import Path

from tqdm import tqdm

import envs  # noqa: F401  (registers the envs)
from envs import sizes
from envs.cli import common as cli
from envs.cli import options
from envs.grasp import GRASP_ENV_IDS
from envs.harness.checkpoint import checkpoint_path
from envs.harness.stopping import SignalStop, StopRequested
from envs.harness.training import RESUMABLE, TRAINING_PAIRS, RunConfig, Trainer
from learners.persistence import writing
from learners.som.config import RULES
from learners.som.hierarchical_config import HierarchicalConfig
from models.puma560.grasp import WIDE

_GRASP_MAP = HierarchicalConfig()

#: The progress bar's label while training, and while the map is evaluated on held-out targets
#: (before the first trial, and every --eval-every trials), which the bar does not count.
TRAINING = "train"
EVALUATING = "train: held-out evaluation ({targets} targets)"


def _text(value: object) -> str:
    """A setting as it is written on the command line."""
    return sizes.format_lattice(value) if isinstance(value, tuple) else str(value)


def resume_conflicts(stored: RunConfig, args: argparse.Namespace, given: set[str]) -> list[str]:
    """Options given with --resume that differ from the run's and may not change."""
    out = []
    for f in fields(RunConfig):
        if f.name in given and f.name not in RESUMABLE:
            ours, theirs = getattr(args, f.name), getattr(stored, f.name)
            if ours != theirs:
                name = f.name.replace("_", "-")
                out.append(f"--{name} {_text(ours)} (the run has {_text(theirs)})")
    size = (stored.width, stored.height)  # --image-size WIDTHxHEIGHT sets both fields
    if "image_size" in given and tuple(args.image_size) != size:
        ours, theirs = sizes.format_size(*args.image_size), sizes.format_size(*size)
        out.append(f"--image-size {ours} (the run has {theirs})")
    return out


def main(argv: list[str] | None = None) -> Path:
    d = RunConfig()
    p = cli.parser(__doc__)
    options.ENV.add(p, default=d.env)
    options.TRIALS.add(p, default=d.trials)
    options.SEED.add(p, default=d.seed)
    add_map_options(p, d)
    options.ORIENTATIONS.add(p, note=f"default {WIDE.spec()}; ball:30: the first releases'")
    p.add_argument("--training-pairs", type=cli.positive_int,
                   help=f"PumaGrasp-v0: exploratory fine moves per training trial, each learned "
                   f"(default {TRAINING_PAIRS}; 1: the papers' one)")  # fmt: skip
    options.SENSING.add(p, default=d.sensing, note=options.run_setting_note("sensing"))
    options.CONTROL.add(p, default=d.control, note=options.run_setting_note("control"))
    options.IMAGE_SIZE.add(p, default=sizes.format_size(d.width, d.height))
    p.add_argument("--keep-arm", action="store_true", help="start each trial where the last ended")
    cli.add_count(p, "--eval-every", d.eval_every, "trials")
    options.EVAL_TRIALS.add(p, default=d.eval_trials)
    options.CHECKPOINT_EVERY.add(p)
    options.OUT.add(p, default=Path("runs/train"))
    p.add_argument("--resume", action="store_true", help="continue the run saved in --out")
    p.add_argument("--force", action="store_true", help="start over in a folder holding a run")
    args = p.parse_args(argv)
    cli.check_image_size(args.env, args.image_size)
    grasp_env = args.env in GRASP_ENV_IDS
    for flag in ("orientation_lattice", "orientations", "training_pairs"):
        if getattr(args, flag) is not None and not grasp_env and not args.resume:
            name = "--" + flag.replace("_", "-")
            cli.fail(f"{name} is for {', '.join(GRASP_ENV_IDS)}, not {args.env}")
    if args.lattice is None:
        args.lattice = _GRASP_MAP.position_lattice if grasp_env else d.lattice

    with SignalStop() as stop:
        if args.resume:
            given = cli.given_options(p, argv)
            if args.force:
                cli.fail("--force starts a run over; it cannot be combined with --resume")
            conflicts = resume_conflicts(Trainer.stored_config(args.out), args, given)
            if conflicts:
                cli.fail(
                    f"on --resume only --trials and --checkpoint-every may change, but "
                    f"{'; '.join(conflicts)}; leave them out or train a new run"
                )
            trainer = Trainer.resume(args.out, args.trials if "trials" in given else None)
        else:
            config = pose_checked(
                env=args.env, sensing=args.sensing, control=args.control, seed=args.seed,
                trials=args.trials, lattice=args.lattice, rule=args.rule, keep_arm=args.keep_arm,
                protocol=args.protocol, width=args.image_size[0], height=args.image_size[1],
                sensing_noise=args.sensing_noise,
                eval_every=args.eval_every, eval_trials=args.eval_trials,
                orientation_lattice=args.orientation_lattice if grasp_env else None,
                orientations=args.orientations if grasp_env else None,
                training_pairs=args.training_pairs if grasp_env else None,
            )  # fmt: skip
            trainer = Trainer(config, args.out, force=args.force)
        try:
            with writing(args.out):  # the metrics log's appends: no space is a user error
                train(trainer, args.checkpoint_every, stop)
        finally:
            trainer.close()
    print(f"trained {trainer.trial} trials; map in {checkpoint_path(args.out)}")
    return args.out


# ---- The map's options. This block is replaced by add_config_options(p, SOMConfig) (and the
# pose map's config) once the configs' fields carry the CLI metadata ("help", "choices", "run").
def add_map_options(p: argparse.ArgumentParser, d: RunConfig) -> None:
    """The reach map's and the pose map's options (flags as given since the first releases)."""
    reach, pose = sizes.format_lattice(d.lattice), sizes.format_lattice(_GRASP_MAP.position_lattice)
    options.LATTICE.add(p, help=f"lattice shape (default {reach}; PumaGrasp-v0: the position "
                        f"lattice, default {pose})")  # fmt: skip
    nested = sizes.format_lattice(_GRASP_MAP.orientation_lattice)
    p.add_argument("--orientation-lattice", type=cli.lattice,
                   help=f"PumaGrasp-v0: the lattice nested at every position node (default "
                   f"{nested})")  # fmt: skip
    p.add_argument("--rule", default=d.rule, choices=RULES)
    options.PROTOCOL.add(
        p,
        default=d.protocol,
        help="mrs: MRS loop with this project's additions; brause: Brause's own (coarse Θ_c, "
        "fine (3.7), learning (3.9)/(3.10), step neighbourhood, one rate)",
    )
    p.add_argument("--sensing-noise", type=cli.nonnegative_float, default=d.sensing_noise,
                   help="px: std of a sensed pixel's error; the map's Widrow-Hoff step corrects "
                   "for it (0: the published step; docs/decisions.md)")  # fmt: skip


# ---- end of the map's options


def pose_checked(**settings: object) -> RunConfig:
    """``RunConfig(**settings)``; on a grasp env a reach-map option is a one-line user error."""
    try:
        return RunConfig(**settings)
    except ValueError as exc:
        if settings["env"] not in GRASP_ENV_IDS:
            raise
        cli.fail(str(exc))
        raise  # not reached: fail exits


def train(trainer: Trainer, checkpoint_every: int, stop: SignalStop) -> None:
    """Run ``trainer`` with a progress bar; on a stop signal say where it stopped and exit.

    The bar's label says when a held-out evaluation runs (it does not advance meanwhile): the
    first comes before the first trial, on the untrained map."""
    evaluating = EVALUATING.format(targets=trainer.config.eval_trials)
    bar = tqdm(
        total=trainer.config.trials,
        initial=trainer.trial,
        desc=evaluating if trainer.pending_eval else TRAINING,
        unit="trial",
        file=sys.stderr,
        mininterval=0.5,
    )

    def progress(trial: int, running: dict[str, float]) -> None:
        bar.set_postfix(
            coarse_mm=f"{running['coarse_mm']:.1f}",
            fine_mm=f"{running['fine_mm']:.2f}",
            refresh=False,
        )
        label = evaluating if trainer.pending_eval else TRAINING
        changed = label != bar.desc
        bar.set_description_str(label, refresh=False)
        bar.update(trial - bar.n)
        if changed:
            bar.refresh()  # shown now: an evaluation may keep the bar still for a while

    try:
        trainer.run(checkpoint_every=checkpoint_every, progress=progress, stop=stop)
    except StopRequested as exc:
        bar.close()
        print(f"{exc} at trial {trainer.trial}; checkpoint saved, continue with --resume")
        raise SystemExit(exc.exit_code) from None
    bar.set_description_str(TRAINING, refresh=False)  # the last evaluation is done
    bar.close()


#: Console entry point ``visuomotor-train``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
