"""Rendered evaluation video: a controller's coarse and fine moves on a reach env, as mp4.

Servo moves are filmed as they happen (30 frames a second of simulated time by default; --speed
2 plays them twice as fast); kinematic moves are shown as a short interpolation, marked as such.
With --compare, a second controller makes the same trials on the same targets, drawn below.
On PumaGrasp-v0 the env's own three views are filmed (the object's markers crosshaired, the
hand's detected markers circled) with the position and orientation errors after each move; its
controllers are pose_ik, pose_jacobian or a trained hierarchical map.

.venv/bin/python scripts/video.py --env PumaReach-v0 --controller runs/puma --compare analytic
.venv/bin/python scripts/video.py --env PumaGrasp-v0 --controller runs/grasp --compare pose_ik
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options
from envs.cli.controllers import (
    NAMED,
    POSE_NAMED,
    check_task,
    controller_spec,
    make_controller,
)
from envs.grasp import GRASP_ENV_IDS
from envs.harness.film import VIDEO_FPS, TrialFilm, side_by_side
from envs.harness.grasp_film import GraspFilm
from envs.harness.streams import seed_env
from envs.harness.video import VideoWriter

#: Most trials of a video: each is seconds of film, rendered frame by frame.
TRIAL_COUNT = cli.count(most=1000, why="each trial is seconds of rendered video")


def controller_name(spec: str, controller) -> str:
    named = spec in NAMED or spec in POSE_NAMED
    return spec if named else f"learned map ({type(controller).__name__}, {Path(spec).name})"


def main(argv: list[str] | None = None) -> Path:
    parser = cli.parser(__doc__)
    options.ENV.add(parser, default="PumaReach-v0")
    options.CONTROLLER.add(parser, required=True)
    parser.add_argument(
        "--compare", type=controller_spec, help="a second controller on the same targets"
    )
    options.TRIALS.add(parser, default=4, type=TRIAL_COUNT)
    options.FINE_MOVES.add(parser)
    options.SEED.add(parser, default=1)
    options.SENSING.add(parser, default="foveated")
    options.CONTROL.add(parser, default="servo")
    parser.add_argument("--fps", type=cli.positive_float, default=VIDEO_FPS)
    parser.add_argument(
        "--speed", type=cli.positive_float, default=1.0, help="simulated s per s of video"
    )
    options.OUT.add(
        parser, type=cli.out_file, default=Path("runs/video/eval.mp4"), help="the video file (.mp4)"
    )
    args = parser.parse_args(argv)  # also finds a read-only folder or a full disk
    if args.out.suffix != ".mp4":
        cli.fail(f"--out {args.out}: the video is an mp4; give a name ending in .mp4")
    with cli.removed_if_refused(args.out.parent):  # a failed video leaves no empty folder
        write_video(args)
    return args.out


def write_video(args: argparse.Namespace) -> None:
    """The video of ``main``'s checked arguments, into ``args.out``."""
    specs = [args.controller] + ([args.compare] if args.compare else [])
    check_task(specs, args.env in GRASP_ENV_IDS)
    runs = []  # (env, controller, film) per controller; the same seed gives the same targets
    pose = args.env in GRASP_ENV_IDS
    for spec in specs:
        if pose:  # the grasp env draws its own views
            env = gym.make(args.env, sensing=args.sensing, control=args.control,
                           render_mode="rgb_array")  # fmt: skip
        else:
            env = gym.make(args.env, sensing=args.sensing, control=args.control)
        controller = make_controller(spec, env, args.seed)
        speed = "real time" if args.speed == 1 else f"{args.speed:g}x real time"
        title = (
            f"{args.env}  {controller_name(spec, controller)}  sensing={args.sensing}  "
            f"control={args.control}  ({speed})"
        )
        seed_env(env, args.seed, "evaluation")  # held-out targets, never trained on
        film = (GraspFilm if pose else TrialFilm)(env, title, args.fps, args.speed)
        runs.append((env, controller, film))
    with VideoWriter(args.out, args.fps) as video:
        for i in cli.progress(range(args.trials), "video", "trial"):
            label = f"trial {i + 1}/{args.trials}"
            films = [film.trial(c, args.fine_moves, label)[1] for _, c, film in runs]
            for frame in side_by_side(films):
                video.write(frame)
    for env, _, film in runs:
        film.close()
        env.close()
    seconds = video.frames / args.fps
    print(f"wrote {video.frames} frames ({seconds:.1f} s at {args.fps:g} fps) to {args.out}")


#: Console entry point ``visuomotor-video``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
