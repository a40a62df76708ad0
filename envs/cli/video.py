"""Rendered evaluation video: a controller's coarse and fine moves on a reach env, as mp4.

.venv/bin/python scripts/video.py --env PumaReach-v0 --controller random --out runs/video/random.mp4
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli.controllers import REACH_ENVS, SPECS, controller_spec, make_controller
from envs.harness.run_folder import check_writable
from envs.harness.trials import Trial, run_trial
from envs.harness.video import VideoWriter, annotate
from envs.reach import SENSING_MODES

#: Video frames per move, so that a viewer can follow each move at a low frame rate.
FRAMES_PER_MOVE = 3


def main(argv: list[str] | None = None) -> Path:
    parser = cli.parser(__doc__)
    parser.add_argument("--env", default="PumaReach-v0", choices=REACH_ENVS)
    parser.add_argument("--controller", required=True, type=controller_spec, help=SPECS)
    parser.add_argument("--trials", type=cli.positive_int, default=4)
    parser.add_argument("--fine-moves", type=cli.nonnegative_int, default=2)
    parser.add_argument("--seed", type=cli.nonnegative_int, default=1)
    parser.add_argument("--sensing", default="foveated", choices=SENSING_MODES)
    parser.add_argument("--control", default="servo", choices=("servo", "kinematic"))
    parser.add_argument("--fps", type=cli.positive_float, default=6.0)
    parser.add_argument("--out", type=Path, default=Path("runs/video/eval.mp4"))
    args = parser.parse_args(argv)
    check_writable(args.out.parent)  # a read-only folder or a full disk, before any work

    env = gym.make(args.env, sensing=args.sensing, control=args.control, render_mode="rgb_array")
    controller = make_controller(args.controller, env, args.seed)
    title = (
        f"{args.env}   {type(controller).__name__}   sensing={args.sensing}  control={args.control}"
    )
    env.reset(seed=args.seed)
    with VideoWriter(args.out, args.fps) as video:
        for i in cli.progress(range(args.trials), "video", "trial"):

            def record(k: int, trial: Trial, i: int = i) -> None:
                move = "target" if k < 0 else ("coarse move" if k == 0 else f"fine move {k}")
                error = "" if k < 0 else f"   error {trial.distances[k] * 1e3:.1f} mm"
                lines = [title, f"trial {i + 1}/{args.trials}   {move}{error}"]
                frame = annotate(env.render(), lines)
                for _ in range(FRAMES_PER_MOVE):
                    video.write(frame)

            run_trial(env, controller, args.fine_moves, on_move=record)
    env.close()
    print(f"wrote {video.frames} frames to {args.out}")
    return args.out


def run() -> None:
    """Console entry point ``visuomotor-video``."""
    cli.run(main)


if __name__ == "__main__":
    run()
