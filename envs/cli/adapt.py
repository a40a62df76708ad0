"""Re-adaptation after a change of the scene: the learned map against the stale exact baselines.

Per arm: train the map for --train-trials trials on the nominal scene; for each change, apply it
and go on for --after trials, evaluating every --every trials on --eval-trials held-out targets.
Writes <out>/<env>/<change>.json, <out>/<env>/curves.png, <out>/table.json and table.md, and a
video of the first change other than "none" (trials before it, just after it and after
recovery, side by side).

.venv/bin/python scripts/adapt.py --out runs/adapt                   # idealised, both arms
.venv/bin/python scripts/adapt.py --sensing render --control servo --pretrained runs/adapt \\
    --warmup 300 --after 1000 --every 500 --eval-trials 100 --changes camera \\
    --video-trials 2 --out runs/adapt-realistic  # realistic, from the idealised maps, sized down
"""

from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import write_json
from envs.harness.training import RunConfig
from envs.reach import REACH_ENV_IDS
from envs.robots import default_reach_env_ids
from envs.studies.adaptation import (
    CHANGES,
    MAP_CONTINUAL,
    AdaptConfig,
    adapt,
    markdown_table,
    pretrain,
    table_row,
    warm_up,
)
from envs.studies.adaptation_media import curves_figure, phases_video
from learners.persistence import write_atomic
from learners.som.config import SOMConfig
from learners.som.controller import VisuomotorSOM


def main(argv: list[str] | None = None) -> list[dict]:
    parser = cli.parser(__doc__)
    parser.add_argument(
        "--envs", nargs="+", default=list(default_reach_env_ids()), choices=REACH_ENV_IDS
    )
    parser.add_argument("--changes", nargs="+", default=list(CHANGES), choices=list(CHANGES))
    options.SENSING.add(
        parser,
        default=RunConfig.sensing,
        choices=options.WHOLE_IMAGE_SENSING,
        note=options.run_setting_note("sensing"),
    )
    options.CONTROL.add(parser, default=RunConfig.control, note=options.run_setting_note("control"))
    options.SEED.add(parser)
    parser.add_argument("--train-trials", type=cli.positive_int, default=10_000)
    cli.add_count(parser, "--pre-every", 2000, "evaluations before the change")
    cli.add_count(parser, "--after", 3000, "trials after the change")
    cli.add_count(parser, "--every", 250, "evaluations after the change")
    options.EVAL_TRIALS.add(parser, default=1000)
    parser.add_argument(
        "--pretrained",
        type=Path,
        help="instead of pre-training, load <PRETRAINED>/<env>/pretrained.npz (e.g. the idealised "
        "run's maps) and train it --warmup trials in this setting before the change",
    )
    parser.add_argument("--warmup", type=cli.positive_int, default=300)
    options.ABAR_OPTION.add(
        parser,
        default=SOMConfig.abar,
        help="Ā of the evaluations' fine moves: local-fit (this project's) or average (MRS)",
    )
    cli.add_count(parser, "--video-trials", 3, "0: no video", least=0)
    options.OUT.add(parser, default=Path("runs/adapt"))
    args = parser.parse_args(argv)
    start = time.monotonic()

    def progress(stage: str, trial: int) -> None:
        print(f"  [{time.monotonic() - start:7.0f} s] {stage}: {trial} trials", flush=True)

    video_change = next((c for c in args.changes if c != "none"), None)
    rows = []
    for env_id in args.envs:
        run = RunConfig.of(
            env=env_id, sensing=args.sensing, control=args.control, seed=args.seed,
            trials=args.train_trials, eval_every=args.pre_every, eval_trials=args.eval_trials,
            abar=args.abar,
        )  # fmt: skip
        base = AdaptConfig(run, after_trials=args.after, every=args.every)
        folder = args.out / env_id
        if args.pretrained is None:
            print(f"{env_id}: pre-training ({args.sensing}, {args.control})", flush=True)
            som, pre = pretrain(base, progress)
        else:
            som = VisuomotorSOM.load(args.pretrained / env_id / "pretrained.npz")
            som = som.with_config(abar=args.abar)
            print(f"{env_id}: {som.t} trials learned; warm-up in {args.sensing}, {args.control}")
            som, pre = warm_up(base, som, args.warmup, progress)
        som.save(folder / "pretrained.npz")
        write_json(folder / "pretraining.json", pre)
        results = []
        for change in args.changes:
            config = replace(base, change=change)
            result, maps = adapt(config, som, progress)
            write_json(folder / f"{change}.json", result)
            results.append(result)
            rows.append(table_row(result))
            print(json.dumps(rows[-1]), flush=True)
            if args.video_trials and change == video_change:
                phases = [
                    ("before the change", {}, som),
                    (f"just after: {result['change']}", CHANGES[change], som),
                    (
                        f"{args.after} trials later (continual)",
                        CHANGES[change],
                        maps[MAP_CONTINUAL],
                    ),
                ]
                video = folder / f"video_{change}.mp4"
                setting = {"sensing": args.sensing, "control": args.control}
                phases_video(env_id, setting, phases, video, args.video_trials, args.seed + 1)
                print(f"  wrote {video}", flush=True)
        title = f"{env_id}, {args.sensing} + {args.control}, {args.eval_trials} held-out targets"
        print(f"  wrote {curves_figure(pre, results, title, folder / 'curves.png')}", flush=True)
    write_json(args.out / "table.json", rows)
    table = markdown_table(rows)
    write_atomic(args.out / "table.md", lambda f: f.write(table.encode()))
    print(table)
    print(f"done in {time.monotonic() - start:.0f} s; table in {args.out / 'table.json'}")
    return rows


#: Console entry point ``visuomotor-adapt``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
