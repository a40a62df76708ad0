"""Build the RIACS data set of Jorgensen (1990): build3dpts, a seeded buildtset split, the plots.

    .venv/bin/python scripts/riacs_dataset.py       # 3° steps, outputs in runs/riacs_dataset
    .venv/bin/python scripts/riacs_dataset.py --stepsize 0.1 --train 2000 --test 500 --no-replace

Writes ``riacs_dataset.npz`` (arrays ``data``, ``train``, ``test``, columns in the config),
``data.csv``, ``train.csv``, ``test.csv`` (header x,y,z,x1,y1,x2,y2,theta1,theta2,theta3),
``axis_projections.png`` (3-D view, XY, XZ and YZ projections as in the report's appendix) and
``summary.json``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from envs.cli import common as cli
from envs.cli import options
from envs.harness.plots import save_figure
from envs.harness.run_folder import write_json
from learners.persistence import save_npz
from models.analyses import riacs_dataset as D
from models.riacs import LINK1, LINK2

KIND, VERSION = "riacs-dataset", 1


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = cli.parser(__doc__)
    options.OUT.add(p, default=Path("runs/riacs_dataset"))
    p.add_argument(
        "--stepsize", type=cli.positive_float, default=D.STEP, help="joint step, rad (default π/60)"
    )
    cli.add_count(p, "--train", 1000, "training rows")
    cli.add_count(p, "--test", 1000, "test rows")
    p.add_argument(
        "--no-replace",
        action="store_true",
        help="disjoint split instead of buildtset's sampling with replacement",
    )
    options.SEED.add(p)
    return p.parse_args(argv)


def plot_projections(data: np.ndarray, path: Path) -> None:
    """Write :func:`projections_figure` to ``path``."""
    save_figure(projections_figure(data), path, dpi=120, bbox_inches=None)


def projections_figure(data: np.ndarray) -> Figure:
    """The data set's effector positions (columns x, y, z of ``data``, one point per row): a 3-D
    view and the XY, XZ and YZ projections, as in the report's appendix."""
    x, y, z = data[:, 0], data[:, 1], data[:, 2]
    fig = plt.figure(figsize=(10, 9))
    ax = fig.add_subplot(2, 2, 1, projection="3d")
    ax.scatter(x, y, z, s=0.3, alpha=0.3)
    ax.set(xlabel="x", ylabel="y", zlabel="z", title="Axis projection of original data set")
    for i, (a, b, la, lb) in enumerate(((x, y, "x", "y"), (x, z, "x", "z"), (y, z, "y", "z"))):
        ax = fig.add_subplot(2, 2, i + 2)
        ax.scatter(a, b, s=0.3, alpha=0.3)
        ax.set(xlabel=la, ylabel=lb, title=f"{la.upper()}{lb.upper()} axis projection")
        ax.set_aspect("equal")
    fig.tight_layout()
    return fig


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    data = D.build3dpts(LINK1, LINK2, args.stepsize)
    rng = np.random.default_rng(args.seed)
    train, test = D.train_test_split(data, args.train, args.test, rng, replace=not args.no_replace)
    sizes = [len(r) for r in D.joint_ranges(LINK1, LINK2, args.stepsize)]
    config = {
        "columns": list(D.COLUMNS),
        "arm1": LINK1,
        "arm2": LINK2,
        "stepsize_rad": args.stepsize,
        "seed": args.seed,
        "replace": not args.no_replace,
    }
    save_npz(
        args.out / "riacs_dataset.npz",
        KIND,
        VERSION,
        config,
        {"data": data, "train": train, "test": test},
    )
    header = ",".join(D.COLUMNS)
    for name, rows in (("data", data), ("train", train), ("test", test)):
        np.savetxt(
            args.out / f"{name}.csv", rows, delimiter=",", header=header, comments="", fmt="%.10g"
        )
    plot_projections(data, args.out / "axis_projections.png")
    summary = {
        **config,
        "rows": len(data),
        "loop_sizes": sizes,
        "train": len(train),
        "test": len(test),
        "min": data.min(axis=0).tolist(),
        "max": data.max(axis=0).tolist(),
    }
    write_json(args.out / "summary.json", summary)
    print(f"build3dpts: step {np.degrees(args.stepsize):.3g}°, loops {sizes} -> {len(data)} rows")
    for c, lo, hi in zip(D.COLUMNS, summary["min"], summary["max"], strict=True):
        print(f"  {c:>7}: [{lo:8.4f}, {hi:8.4f}]")
    print(
        f"train {len(train)} / test {len(test)} rows "
        f"({'with' if not args.no_replace else 'without'} replacement, seed {args.seed})"
    )
    print(f"wrote {args.out}")


#: Console entry point ``visuomotor-riacs-dataset``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
