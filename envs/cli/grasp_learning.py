"""Error against training trials per leaf of the hierarchical map on the idealised grasp task.

    .venv/bin/python scripts/grasp_learning.py --out docs/assets/grasp_learning.png

For each budget a fresh map trains on its own trials (exact projection, joints set exactly:
envs.studies.grasp_learning), then moves to the held-out targets with a coarse and --fine-moves
fine moves; the exact pose IK through the same cameras is the floor. Prints the table (Markdown:
mean position in mm and % of reach, orientation in degrees, after each move; every target
counted) and writes the plot (log x) beside the published rows.
"""

from __future__ import annotations

from pathlib import Path

from envs.cli import common as cli
from envs.cli import options
from envs.harness.run_folder import check_writable
from envs.studies.grasp_learning import (
    FINE_MOVES,
    TEST_TARGETS,
    TRIALS_PER_LEAF,
    format_table,
    table,
)
from learners.som.hierarchical_config import HierarchicalConfig


def main(argv: list[str] | None = None) -> Path:
    p = cli.parser(__doc__)
    options.SEED.add(p)
    options.TARGETS.add(p, default=TEST_TARGETS, help="held out")
    options.FINE_MOVES.add(p, default=FINE_MOVES)
    p.add_argument("--trials-per-leaf", type=cli.positive_float, nargs="+",
                   default=list(TRIALS_PER_LEAF), help="training budgets")  # fmt: skip
    options.OUT.add(
        p, type=cli.out_file, default=Path("runs/grasp_learning.png"), help="the figure's file"
    )
    args = p.parse_args(argv)
    check_writable(args.out.parent)
    from envs.studies.grasp_learning_plot import write

    config = HierarchicalConfig()
    rows = table(args.seed, config, tuple(args.trials_per_leaf), args.targets, args.fine_moves)
    print(format_table(rows))
    lattice = " × ".join(
        "×".join(map(str, shape)) for shape in (config.position_lattice, config.orientation_lattice)
    )
    floor = rows[-1]
    title = (
        f"HierarchicalSOM {lattice} on the idealised grasp task (project, kinematic), seed "
        f"{args.seed}, {args.targets} held-out targets\nexact pose IK floor at most "
        f"{floor.position_pct.max():.0e} % and {floor.orientation_deg.max():.0e}°"
    )
    write(rows, title, args.out)
    print(f"plot in {args.out}")
    return args.out


#: Console entry point ``visuomotor-grasp-learning``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
