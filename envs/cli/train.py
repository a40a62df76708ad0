"""Train the visuomotor SOM on a reach env, headless, with checkpoints and held-out evaluations.

    .venv/bin/python scripts/train.py --env RiacsReach-v0 --trials 10000 --out runs/riacs
    .venv/bin/python scripts/train.py --out runs/riacs --resume   # continue a stopped run
    .venv/bin/python scripts/train.py --env PumaGrasp-v0 --trials 6144 --out runs/grasp

On PumaGrasp-v0 (the hand's position and orientation) it trains the hierarchical map: --lattice
is its position lattice (default 8x8x6) and --orientation-lattice the lattice nested at every
position node (default 2x2x2); --theta-target (--rule), --protocol, --abar and --sensing-noise
belong to the reach map only. The
held-out evaluations then also give the orientation error in degrees.

Writes OUT/checkpoint.npz (the checkpoint: the map, where the run stands, the simulation state; it
loads as a map) and OUT/metrics.jsonl (a held-out evaluation every --eval-every trials: errors
after the coarse move and each fine move in mm, % of the robot's reach and pixels).

Ctrl-C or SIGTERM finishes the current trial, saves and exits (130 or 143); --resume then
continues exactly as if the run had never stopped, also after a kill or a power cut. One
process at a time may write to OUT; a fresh run refuses a folder that holds a run unless
--force. On --resume only --trials (to extend the run) and --checkpoint-every may change; the
run keeps its own --checkpoint-every unless it is given again.

--workers N (N >= 2) runs the trials in N worker processes, each with its own env, in rounds: the
workers run a round's trials with the map of its start, the learner learns them in order. Trial
k's target and exploration come from (seed, k), so the map is the same for every N >= 2 and after
a kill; a worker that dies is started again and its round redone, and Ctrl-C abandons the
round (redone on --resume). --workers 1 (the default) is the one-process training, trial after
trial. With --address (auto, HOST:PORT or local; the extra sweep) the workers are Ray actors on
that cluster, one CPU each, and give the same map; --resume continues with or without it.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import fields
from pathlib import Path
from typing import Any

from tqdm import tqdm

import envs  # noqa: F401  (registers the envs)
from envs import sizes
from envs.cli import common as cli
from envs.cli import options
from envs.cli.config_options import add_config_options
from envs.grasp import GRASP_ENV_IDS
from envs.harness.checkpoint import checkpoint_path
from envs.harness.stopping import SignalStop, StopRequested
from envs.harness.training import (
    REACH_ONLY,
    RESUMABLE,
    SETTINGS,
    TRAINING_PAIRS,
    RunConfig,
    Trainer,
)
from envs.harness.workers import ROUND_TRIALS
from envs.limits import MAX_WORKERS
from learners.persistence import writing
from learners.som.config import RENAMED, SOMConfig
from learners.som.hierarchical_config import HierarchicalConfig
from learners.som.options import run_key, run_options, run_spelling
from models.puma560.grasp import WIDE

#: --address with a run of one worker (the one-process training, which has no workers to place).
_ONE_WORKER = (
    "--address {address} runs the --workers as Ray actors, but the run has {workers} worker; "
    "give --workers N (N >= 2) or leave out --address"
)
#: The progress bar's label while training, and while the map is evaluated on held-out targets
#: (before the first trial, and every --eval-every trials), which the bar does not count.
TRAINING = "train"
EVALUATING = "train: held-out evaluation ({targets} targets)"


def _text(value: object) -> str:
    """A setting as it is written on the command line."""
    return sizes.format_lattice(value) if isinstance(value, (tuple, list)) else str(value)


def resume_conflicts(stored: RunConfig, args: argparse.Namespace, given: set[str]) -> list[str]:
    """Options given with --resume that differ from the run's and may not change."""
    ours = {f.name: getattr(args, f.name) for f in fields(RunConfig) if hasattr(args, f.name)}
    ours |= map_settings(args, given)
    settings = stored.settings()
    out = []
    for dest in sorted(given):
        key = run_key(_MAP_FIELDS[dest]) if dest in _MAP_FIELDS else dest
        if key in RESUMABLE or key not in ours:
            continue
        mine, theirs = ours[key], settings.get(key, SETTINGS.get(key))
        if mine != theirs:
            flag = "--" + dest.replace("_", "-")
            out.append(f"{flag} {_shown(dest, mine)} (the run has {_shown(dest, theirs)})")
    size = (stored.width, stored.height)  # --image-size WIDTHxHEIGHT sets both fields
    if "image_size" in given and tuple(args.image_size) != size:
        ours_size, theirs_size = sizes.format_size(*args.image_size), sizes.format_size(*size)
        out.append(f"--image-size {ours_size} (the run has {theirs_size})")
    return out


def _shown(dest: str, value: Any) -> str:
    """The run setting ``value`` of the flag ``dest`` as the flag spells it."""
    f = _MAP_FIELDS.get(dest)
    if f is not None and "stored_values" in f.metadata:
        value = {v: k for k, v in f.metadata["stored_values"].items()}[value]
    return _text(value)


def main(argv: list[str] | None = None) -> Path:
    d = RunConfig()
    p = cli.parser(__doc__)
    options.ENV.add(p, default=d.env)
    options.TRIALS.add(p, default=d.trials)
    options.SEED.add(p, default=d.seed)
    add_map_options(p)
    options.ORIENTATIONS.add(p, note=f"default {WIDE.spec()}; ball:30: the first releases'")
    p.add_argument("--training-pairs", type=cli.positive_int,
                   help=f"PumaGrasp-v0: exploratory fine moves per training trial, each learned "
                   f"(default {TRAINING_PAIRS}; 1: the papers' one)")  # fmt: skip
    options.SENSING.add(p, default=d.sensing, note=options.run_setting_note("sensing"))
    options.CONTROL.add(p, default=d.control, note=options.run_setting_note("control"))
    options.IMAGE_SIZE.add(p, default=sizes.format_size(d.width, d.height))
    p.add_argument("--keep-arm", action="store_true", help="start each trial where the last ended")
    p.add_argument("--workers", type=cli.count(1, MAX_WORKERS, "processes, each with an env"),
                   default=d.workers,
                   help=f"collect the trials in {ROUND_TRIALS}-trial rounds with this many worker "
                   "processes, one learner learning them in order (default 1: one process, trial "
                   "after trial); the map depends on the seed, not on N >= 2")  # fmt: skip
    options.ADDRESS.add(p, note="the --workers run there as Ray actors (default: local "
                        "processes), the same map; not stored with the run")  # fmt: skip
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
    given = cli.given_options(p, argv)
    if args.address is not None and args.workers < 2 and not args.resume:
        cli.fail(_ONE_WORKER.format(address=args.address, workers=args.workers))
    if args.keep_arm and args.workers > 1:
        cli.fail(
            f"--keep-arm starts a trial where the last ended, which {args.workers} workers "
            "running trials side by side cannot; leave out --keep-arm or --workers"
        )
    reach_only = sorted(d for d in given if d in _REACH_FLAGS)
    if grasp_env and reach_only and not args.resume:
        flags = ", ".join("--" + d.replace("_", "-") for d in reach_only)
        cli.fail(
            f"{flags}: the reach map's option(s) do not apply to {args.env}'s hierarchical "
            "map; leave them out"
        )

    with SignalStop() as stop, cli.removed_if_refused(args.out):  # a refused run leaves no folder
        if args.resume:
            if args.force:
                cli.fail("--force starts a run over; it cannot be combined with --resume")
            stored = Trainer.stored_config(args.out)
            if args.address is not None and stored.workers < 2:
                cli.fail(_ONE_WORKER.format(address=args.address, workers=stored.workers))
            conflicts = resume_conflicts(stored, args, given)
            if conflicts:
                cli.fail(
                    f"on --resume only --trials and --checkpoint-every may change, but "
                    f"{'; '.join(conflicts)}; leave them out or train a new run"
                )
            trainer = Trainer.resume(
                args.out,
                args.trials if "trials" in given else None,
                args.checkpoint_every if "checkpoint_every" in given else None,  # else the run's
                args.address,
            )
        else:
            config = checked(
                env=args.env, sensing=args.sensing, control=args.control, seed=args.seed,
                trials=args.trials, keep_arm=args.keep_arm, workers=args.workers,
                width=args.image_size[0], height=args.image_size[1],
                eval_every=args.eval_every, eval_trials=args.eval_trials,
                orientations=args.orientations if grasp_env else None,
                training_pairs=args.training_pairs if grasp_env else None,
                **map_settings(args, given),
            )  # fmt: skip
            trainer = Trainer(
                config, args.out, args.force, args.checkpoint_every, address=args.address
            )
        try:
            with writing(args.out):  # the metrics log's appends: no space is a user error
                train(trainer, trainer.checkpoint_every, stop)
        finally:
            trainer.close()
    print(f"trained {trainer.trial} trials; map in {checkpoint_path(args.out)}")
    return args.out


# ---- The map's options: flags generated from the run options of its configs.
#: --rule (mrs, brause), the old flag of --theta-target, still taken; its values are the run's.
OLD_RULE = RENAMED["rule"][1]
#: The map's run options by their flags' dests (the grasp map's position lattice is --lattice).
_MAP_FIELDS = {
    f.name: f
    for f in run_options(SOMConfig) + run_options(HierarchicalConfig)
    if f.name != "position_lattice"
}
#: The flags of the reach map's own options (``REACH_ONLY``), the old --rule among them.
_REACH_FLAGS = {d for d, f in _MAP_FIELDS.items() if run_key(f) in REACH_ONLY} | {"rule"}


def add_map_options(p: argparse.ArgumentParser) -> None:
    """The map's run options as flags, from ``SOMConfig`` (the reach map) and
    ``HierarchicalConfig`` (PumaGrasp-v0's map, whose position lattice is --lattice)."""
    grasp, pose = ", ".join(GRASP_ENV_IDS), HierarchicalConfig()
    group = p.add_argument_group("the map's options (learners/som/config.py)")
    add_config_options(
        group,
        SOMConfig,
        defaults={"lattice": None},
        notes={"lattice": f"{grasp}: the position lattice, default "
                          f"{sizes.format_lattice(pose.position_lattice)}"},
    )  # fmt: skip
    add_config_options(
        group,
        HierarchicalConfig,
        skip=("position_lattice", "refine"),
        defaults={"orientation_lattice": None},
        notes={"orientation_lattice": f"{grasp} only, default "
                                      f"{sizes.format_lattice(pose.orientation_lattice)}"},
    )  # fmt: skip
    group.add_argument("--rule", choices=tuple(OLD_RULE),
                       help="the old name of --theta-target: mrs = coarse-error (the default), "
                       "brause = fine-error")  # fmt: skip


def map_settings(args: argparse.Namespace, given: set[str]) -> dict[str, Any]:
    """The map's options on the command line, flat as ``RunConfig.of`` takes them (a lattice
    left out: the env's map's default)."""
    values = {name: getattr(args, name, None) for name in _MAP_FIELDS}
    rule = getattr(args, "rule", None)
    if rule is not None:
        if "theta_target" in given and values["theta_target"] != OLD_RULE[rule]:
            cli.fail("--rule is the old name of --theta-target; give one of them")
        values["theta_target"] = OLD_RULE[rule]
    return {run_key(_MAP_FIELDS[k]): run_spelling(_MAP_FIELDS[k], v)
            for k, v in values.items() if v is not None}  # fmt: skip


def checked(**settings: Any) -> RunConfig:
    """``RunConfig.of(**settings)``; a setting it refuses is a one-line user error."""
    try:
        return RunConfig.of(**settings)
    except ValueError as exc:
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
