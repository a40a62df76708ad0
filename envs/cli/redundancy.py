"""The redundancy of a map trained on a 7-joint arm: the swivel (elbow) angle each neuron chose,
its largest jump between lattice neighbours, and the held-out commands against the joint ranges.

    .venv/bin/python scripts/train.py --env PandaReach-v0 --trials 10000 --seed 0 --out runs/panda
    .venv/bin/python scripts/redundancy.py --run runs/panda --targets 1000

Prints the jumps of the swivel angle and of each joint between neighbours (largest, median, 99th
percentile), the commands outside the joint ranges and at a range end, and the held-out errors
(the same targets as ``evaluate.py --run RUN --seed SET``). Writes OUT/redundancy.json and the
figure OUT/redundancy.png (the swivel angle over the workspace).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli import common as cli
from envs.cli import options
from envs.cli.controllers import run_folder
from envs.harness.run_folder import write_json
from envs.studies import redundancy_plot
from envs.studies.redundancy import RedundancyError, measure

JSON_FILE = "redundancy.json"
FIGURE_FILE = "redundancy.png"


def main(argv: list[str] | None = None) -> dict:
    p = cli.parser(__doc__)
    p.add_argument(
        "--run", type=Path, required=True, help="a train.py run folder on all of an arm's joints"
    )
    options.TARGETS.add(p)
    options.FINE_MOVES.add(p)
    options.EVALUATION_SET.add(p)
    options.OUT.add(p, help="default: RUN/redundancy")
    args = p.parse_args(argv)
    if args.out is not None:
        cli.check_out("--out", args.out, folder=True)  # a mistake there is named first
    try:
        run = run_folder(str(args.run))
    except argparse.ArgumentTypeError as exc:
        p.error(f"argument --run: {exc}")
    out = args.out or run / "redundancy"
    cli.check_out("--out", out, folder=True)
    try:
        result = measure(run, args.targets, args.seed, args.fine_moves)
    except RedundancyError as exc:
        cli.fail(str(exc))
    summary = result.summary()
    print(report(summary))
    with cli.removed_if_refused(out):
        out.mkdir(parents=True, exist_ok=True)
        write_json(out / JSON_FILE, summary)
        redundancy_plot.write(result, out / FIGURE_FILE)
    print(f"wrote {out / JSON_FILE} and {out / FIGURE_FILE}")
    return summary


def report(summary: dict) -> str:
    """The printed table of :meth:`~envs.studies.redundancy.Redundancy.summary`."""
    e = summary["evaluation"]
    moves = ["coarse", *(f"fine {k}" for k in range(1, len(e["mean_mm"])))]
    lines = [
        f"{summary['env']}  sensing={summary['sensing']}  control={summary['control']}  "
        f"lattice {'x'.join(map(str, summary['lattice']))} "
        f"({summary['neighbour_pairs']} neighbour pairs), {e['trials']} held-out targets",
        "held-out mean error: "
        + ", ".join(
            f"{m} {mm:.3f} mm ({pct:.3f} %)"
            for m, mm, pct in zip(moves, e["mean_mm"], e["mean_percent_reach"], strict=True)
        ),
        f"{'jumps between neighbours [°]':<30} {'largest':>8} {'median':>8} {'p99':>8}",
    ]
    rows = [("swivel angle ψ", summary["swivel_jumps"])]
    rows += [(f"joint {j + 1}", s) for j, s in enumerate(summary["joint_jumps"])]
    for name, s in rows:
        lines.append(
            f"{name:<30} {s['max_deg']:>8.2f} {s['median_deg']:>8.2f} {s['p99_deg']:>8.2f}"
        )
    low, high = summary["swivel_range_deg"]
    turn = summary["fine_turn_deg"]
    lines.append(f"ψ over the neurons: {low:.1f}° .. {high:.1f}°; the fine moves turn it by at "
                 f"most {turn['max']:.2f}° (p99 {turn['p99']:.2f}°)")  # fmt: skip
    for name, c in summary["commands"].items():
        lines.append(f"{name} commands: {c['commands']}, outside the joint ranges "
                     f"{c['outside_ranges']}, at a range end {c['at_a_limit']}")  # fmt: skip
    return "\n".join(lines)


#: Console entry point ``visuomotor-redundancy``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
