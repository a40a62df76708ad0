"""Train NATEnet on PumaTrack-v0 and compare its path tracking with the exact inverse Jacobian,
a fixed-grid net of the same size (no allocation) and the untrained net.

    .venv/bin/python scripts/train_natenet.py     # default run, ~1-2 min, writes runs/natenet
    .venv/bin/python scripts/train_natenet.py --train-paths 600 --out runs/natenet_long

Training: one random path (circle or line) per episode, tracked by the net being trained with
Gaussian exploration noise on every joint command; every observed move (Δθ, Δx) is one learning
step. Evaluation: unseen circles of radius 0.1 m, 100 steps per revolution, and unseen lines.
Writes ``metrics.json``, ``natenet.npz``, ``fixed_grid.npz``, plots and ``tracked_circle.mp4``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from envs.cli import common as cli
from envs.cli import options
from envs.studies.natenet_tracking import TrackingStudy, track_study
from envs.track import SENSING_MODES as TRACK_SENSING


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    d = TrackingStudy  # the defaults
    ap = cli.parser(__doc__)
    options.OUT.add(ap, default=Path("runs/natenet"))
    options.SEED.add(ap, default=d.seed)
    ap.add_argument("--train-paths", type=cli.positive_int, default=d.train_paths)
    cli.add_count(ap, "--test-paths", d.test_paths, "per test set (circles, lines)")
    ap.add_argument(
        "--exploration", type=cli.nonnegative_float, default=d.exploration,
        help="joint noise std, rad",
    )  # fmt: skip
    ap.add_argument(
        "--input-dim",
        type=int,
        default=d.input_dim,
        choices=(5, 6),
        help="net input: θ1..θ5 (θ6 does not change J) or all six joints",
    )
    for name in ("lam", "eta", "T0", "e_f", "tau", "T_a", "max_nodes", "gain"):  # NATEnet's
        kind = cli.positive_int if name == "max_nodes" else cli.positive_float
        ap.add_argument("--" + name.replace("_", "-"), type=kind, default=getattr(d, name))
    options.SENSING.add(ap, default=d.sensing, choices=TRACK_SENSING)
    ap.add_argument("--no-video", action="store_true")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    return track_study(TrackingStudy(**vars(parse_args(argv))), cli.progress)


#: Console entry point ``visuomotor-train-natenet``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
