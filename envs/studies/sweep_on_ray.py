"""Running a sweep's cells as Ray tasks, on a local Ray instance or an existing cluster, and
writing the results table (CSV and JSON).

Finished cells (cell.json present) are skipped. A cell whose worker dies (killed, out of
memory, node lost) is retried by Ray (``retries`` times) and resumes from its last checkpoint,
so its result is the same as that of an unbroken run. Ray is optional (extra ``sweep``).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from envs.harness.ray_cluster import check_reachable, need_ray, start_ray
from envs.harness.run_folder import write_json
from envs.harness.training import RunConfig
from envs.studies.sweep_grid import CELL_FILE, PROGRESS_FILE, cell_name, neurons, run_cell
from learners.persistence import write_atomic

#: Local Ray: this many CPUs (the machine is shared; one cell per CPU).
DEFAULT_CPUS = 2
#: Ray retries of a cell whose worker died.
DEFAULT_RETRIES = 3
#: Seconds between progress lines while cells run.
PROGRESS_EVERY_S = 10.0
TABLE_JSON, TABLE_CSV = "results.json", "results.csv"


def _cell_task(config: dict, folder: str, checkpoint_every: int) -> dict:
    import envs  # noqa: F401  (registers the envs in the worker; chooses the GL back-end)

    return run_cell(RunConfig.from_stored(config), Path(folder), checkpoint_every)


def run_sweep(
    configs: list[RunConfig],
    out: Path,
    address: str | None = None,
    num_cpus: int = DEFAULT_CPUS,
    retries: int = DEFAULT_RETRIES,
    checkpoint_every: int = 1000,
    log: Callable[[str], None] = print,
) -> list[dict[str, Any]]:
    """Run every unfinished cell of ``configs`` under ``out/cells`` and write the table.

    Returns the rows of the finished cells, in the order of ``configs``.
    """
    if address is not None:
        check_reachable(address)  # before anything: ray.init would wait for an absent head
    ray = need_ray("a sweep")

    cells = Path(out) / "cells"
    folders = [cells / cell_name(c) for c in configs]
    todo = [(c, f) for c, f in zip(configs, folders, strict=True) if not (f / CELL_FILE).exists()]
    log(f"{len(configs)} cells, {len(configs) - len(todo)} finished before, {len(todo)} to run")
    started_here = not ray.is_initialized()
    if todo and started_here:
        start_ray(address, num_cpus)
    try:
        task = ray.remote(num_cpus=1, max_retries=retries)(_cell_task)
        todo.sort(key=lambda cell: -cell[0].trials * neurons(cell[0]))  # long first
        pending = {task.remote(c.to_stored(), str(f), checkpoint_every): f for c, f in todo}
        failed: list[str] = []
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=PROGRESS_EVERY_S)
            if not ready:
                log(_progress(pending.values(), configs, folders))
            for ref in ready:
                folder = pending.pop(ref)
                try:
                    row = ray.get(ref)
                    degrees = f", deg {row['mean_deg']}" if "mean_deg" in row else ""
                    log(f"done {folder.name}: mean mm after each move {row['mean_mm']}{degrees}")
                except ray.exceptions.RayError as exc:  # the cell raised, or its workers kept dying
                    failed.append(folder.name)
                    log(f"failed {folder.name} after {retries} retries: {exc}")
    finally:
        if todo and started_here:
            ray.shutdown()
    rows = [json.loads((f / CELL_FILE).read_text()) for f in folders if (f / CELL_FILE).exists()]
    write_table(rows, Path(out))
    if failed:
        log(f"{len(failed)} cells failed: {', '.join(failed)}; run the sweep again to retry")
    return rows


def _progress(pending, configs: list[RunConfig], folders: list[Path]) -> str:
    """One line: cells finished, the checkpointed trial of each started cell, cells waiting."""
    trials = {f: c.trials for c, f in zip(configs, folders, strict=True)}
    done = sum((f / CELL_FILE).exists() for f in folders)
    started = [f for f in pending if (f / PROGRESS_FILE).exists()]
    parts = [
        f"{f.name.rsplit('_', 1)[0]} {json.loads((f / PROGRESS_FILE).read_text())['trial']}"
        f"/{trials[f]}"
        for f in started
    ]
    waiting = len(pending) - len(started)
    return f"[{done}/{len(folders)} done] " + "; ".join([*parts, f"{waiting} not checkpointed yet"])


def write_table(rows: list[dict[str, Any]], out: Path) -> None:
    """results.json (rows as they are) and results.csv (lists as "a;b;c"), atomically."""
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / TABLE_JSON, rows)
    columns = list(dict.fromkeys(k for row in rows for k in row))
    text = io.StringIO()
    writer = csv.DictWriter(text, columns)
    writer.writeheader()
    for row in rows:
        writer.writerow(
            {k: ";".join(map(str, v)) if isinstance(v, list) else v for k, v in row.items()}
        )
    write_atomic(out / TABLE_CSV, lambda f: f.write(text.getvalue().encode()))
