"""Train the visuomotor SOM on a reach env, headless, with checkpoints and held-out evaluations.

    python scripts/train.py --env RiacsReach-v0 --trials 10000 --out runs/riacs
    python scripts/train.py --out runs/riacs --resume        # continue an interrupted run

Writes OUT/som.npz (the map), OUT/trainer.json (where the run stands) and OUT/metrics.jsonl
(a held-out evaluation every --eval-every trials: errors after the coarse move and each fine
move in mm, % of the robot's reach and pixels).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tqdm import tqdm

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.training import RunConfig, Trainer


def parse_lattice(text: str) -> tuple[int, ...]:
    try:
        shape = tuple(int(n) for n in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--lattice wants sizes like 12,7,4, got {text!r}"
        ) from None
    if not shape or min(shape) < 1:
        raise argparse.ArgumentTypeError(f"--lattice sizes must be positive, got {text!r}")
    return shape


def main(argv: list[str] | None = None) -> Path:
    d = RunConfig()
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default=d.env, choices=("RiacsReach-v0", "PumaReach-v0"))
    p.add_argument("--trials", type=int, default=d.trials)
    p.add_argument("--seed", type=int, default=d.seed)
    p.add_argument("--lattice", type=parse_lattice, default=d.lattice, help="e.g. 12,7,4")
    p.add_argument("--rule", default=d.rule, choices=("mrs", "brause"))
    p.add_argument(
        "--protocol",
        default=d.protocol,
        choices=("mrs", "brause"),
        help="mrs: MRS loop with this project's additions; brause: Brause's own (coarse Θ_c, "
        "fine (3.7), learning (3.9)/(3.10), step neighbourhood, one rate)",
    )
    p.add_argument("--sensing", default=d.sensing, choices=("render", "project"))
    p.add_argument("--control", default=d.control, choices=("servo", "kinematic"))
    p.add_argument("--keep-arm", action="store_true", help="start each trial where the last ended")
    p.add_argument("--eval-every", type=int, default=d.eval_every)
    p.add_argument("--eval-trials", type=int, default=d.eval_trials)
    p.add_argument("--checkpoint-every", type=int, default=1000)
    p.add_argument("--out", type=Path, default=Path("runs/train"))
    p.add_argument("--resume", action="store_true", help="continue the run saved in --out")
    args = p.parse_args(argv)

    if args.resume:
        trainer = Trainer.resume(args.out)
    else:
        config = RunConfig(
            env=args.env, sensing=args.sensing, control=args.control, seed=args.seed,
            trials=args.trials, lattice=args.lattice, rule=args.rule, keep_arm=args.keep_arm,
            protocol=args.protocol,
            eval_every=args.eval_every, eval_trials=args.eval_trials,
        )  # fmt: skip
        trainer = Trainer(config, args.out)
    bar = tqdm(
        total=trainer.config.trials,
        initial=trainer.trial,
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
        bar.update(trial - bar.n)

    try:
        trainer.run(checkpoint_every=args.checkpoint_every, progress=progress)
    except KeyboardInterrupt:
        bar.close()
        print(f"\ninterrupted at trial {trainer.trial}; checkpoint saved, continue with --resume")
        raise SystemExit(130) from None
    finally:
        trainer.close()
    bar.close()
    print(f"trained {trainer.trial} trials; map in {args.out / 'som.npz'}")
    return args.out


if __name__ == "__main__":
    main()
