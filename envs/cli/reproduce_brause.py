"""Reproduce Brause (1989) §5-6 and appendix B for the PUMA 560: storage table 6a, the
linear-approximation error e^LA along a straight path (Figs. 5f-5i, fit 5.7-5.8) and over the
whole reachable workspace (slope scan), the optimal storage resolution (§6.2, appendix B, Figs.
6.2 and B.1), and e^LA of learned Kohonen maps, trained with Brause's own protocol (coarse Θ_c,
fine (3.7), learning (3.9)/(3.10), step neighbourhood, one rate) and with the MRS loop (rule
"mrs", Gaussian RITT3 neighbourhood, averaged coarse move, exploration: this project's additions).

    .venv/bin/python scripts/reproduce_brause.py             # everything, outputs in runs/brause
    .venv/bin/python scripts/reproduce_brause.py --no-som    # without the learned maps, seconds

Outputs: ``brause.json`` (all numbers), ``fig5f_joints.png``, ``fig5g_joint_error.png``,
``fig5h_cartesian_error.png``, ``fig5i_fit.png``, ``fig6_2_storage_error.png``,
``figB_1_optimal_resolution.png``: the study is ``envs/studies/brause_reproduction.py``; see
``models/analyses/brause_linear_error.py`` and ``models/analyses/brause_optimal_resolution.py``
for the definitions and the readings of garbled equations.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from envs.cli import common as cli
from envs.cli import options
from envs.studies.brause_reproduction import SOM_LATTICES, reproduce
from models.analyses import brause_linear_error as B


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = cli.parser(__doc__)
    options.OUT.add(p, default=Path("runs/brause"))
    cli.add_count(p, "--points", 401, "samples along the path")
    p.add_argument(
        "--edge", type=cli.positive_float, default=B.BRAUSE_EDGE, help="workspace edge X (m)"
    )
    p.add_argument(
        "--dx", type=cli.positive_float, default=B.DX, help="central-difference step of (5.4), m"
    )
    p.add_argument("--no-som", action="store_true", help="skip the learned maps")
    p.add_argument(
        "--scan-spacing",
        type=cli.positive_float,
        default=B.SCAN_SPACING,
        help="grid spacing (m) of the slope scan over the workspace",
    )
    p.add_argument(
        "--lattices",
        type=cli.positive_int,
        nargs="+",
        default=list(SOM_LATTICES),
        help="SOM lattice sizes n (n×n×n neurons)",
    )
    options.SEED.add(p)
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    return reproduce(
        args.out, args.points, args.edge, args.dx, args.scan_spacing, tuple(args.lattices),
        args.seed, som=not args.no_som,
    )  # fmt: skip


#: Console entry point ``visuomotor-reproduce-brause``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
