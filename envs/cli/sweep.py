"""Run a grid of training runs on Ray (local by default) and collect one results table.

    .venv/bin/python scripts/sweep.py --grid robot=riacs,puma --grid lattice=3,4,6,8 \\
        --grid seed=0,1 --grid trials=1000 --out runs/sweep
    .venv/bin/python scripts/sweep.py --spec sweep.yaml --out runs/sweep      # the grid in a file
    .venv/bin/python scripts/sweep.py --spec sweep.yaml --address HEAD:6379   # on a Ray cluster
    .venv/bin/python scripts/sweep.py --grid robot=grasp --grid lattice=3,4,6 \\
        --grid orientation_lattice=1,2 --grid trials_per_neuron=2 --out runs/grasp-sweep   # pose

Axes: robot (a robot's word in the registry, listed under --grid; grasp: the grasp task
PumaGrasp-v0; or env) and every training setting of scripts/train.py (lattice as 12x7x4 or n
for n×n×n, rule, refine, sensing, control, image_size as 640x480, trials, seed, ...), plus
trials_per_neuron k (trials at least k·N).
On grasp, lattice is the hierarchical map's position lattice (default 8x8x6) and
orientation_lattice the one nested at every node (default 2x2x2); N counts the leaves, and the
rows add the orientation error in degrees (mean_deg, median_deg, p90_deg after each move).
A spec file (JSON or YAML) maps axes to a value or a list of values; --grid adds to it.
Writes OUT/cells/<cell>/ (run folders), OUT/results.csv, OUT/results.json and
OUT/error_vs_neurons.png. Run it again to finish or extend a sweep: finished cells are skipped.
"""

from __future__ import annotations

import json
from pathlib import Path

from envs.cli import common as cli
from envs.cli import options
from envs.robots import sweep_names
from envs.studies.sweep_grid import expand
from envs.studies.sweep_on_ray import DEFAULT_CPUS, DEFAULT_RETRIES, run_sweep
from envs.studies.sweep_plots import error_vs_neurons


def load_spec(path: Path) -> dict:
    """The grid in the JSON or YAML file ``path``; a file that cannot be read or parsed is a
    one-line user error."""
    try:
        text = path.read_text()
        if path.suffix in (".yaml", ".yml"):
            import yaml  # in the extra "sweep"

            try:
                return yaml.safe_load(text) or {}
            except yaml.YAMLError as exc:
                raise ValueError(str(exc)) from None
        return json.loads(text)
    except (OSError, ValueError) as exc:
        cli.fail(f"--spec {path}: {exc}")


def parse_grid(items: list[str]) -> dict[str, list[str]]:
    grid = {}
    for item in items:
        axis, sep, values = item.partition("=")
        if not sep or not values:
            cli.fail(f"--grid wants AXIS=V1,V2,..., got {item!r}")
        grid[axis.strip()] = [v.strip() for v in values.split(",")]
    return grid


def main(argv: list[str] | None = None) -> list[dict]:
    p = cli.parser(__doc__)
    p.add_argument("--spec", type=Path, help="JSON or YAML file: axis -> value or list")
    p.add_argument(
        "--grid",
        action="append",
        default=[],
        help=f"AXIS=V1,V2,... (repeatable); robot= takes {', '.join(sweep_names())}",
    )
    options.OUT.add(p, default=Path("runs/sweep"))
    options.ADDRESS.add(p, note="default: a local Ray instance of --num-cpus CPUs")
    cli.add_count(p, "--num-cpus", DEFAULT_CPUS, "local Ray CPUs")
    cli.add_count(p, "--retries", DEFAULT_RETRIES, "per cell", least=0)
    options.CHECKPOINT_EVERY.add(p)
    args = p.parse_args(argv)
    grid = {**(load_spec(args.spec) if args.spec else {}), **parse_grid(args.grid)}
    try:
        configs = expand(grid)
    except (ValueError, TypeError) as exc:
        cli.fail(f"bad grid: {exc}")
    rows = run_sweep(
        configs, args.out, args.address, args.num_cpus, args.retries, args.checkpoint_every
    )
    if rows:
        figure = error_vs_neurons(rows, args.out / "error_vs_neurons.png")
        print(f"{len(rows)} cells in {args.out / 'results.csv'}; figure {figure}")
    return rows


#: Console entry point ``visuomotor-sweep``.
run = cli.entry_point(main)


if __name__ == "__main__":
    run()
