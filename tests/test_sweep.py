"""Sweeps: grid expansion and all-trials-counted errors; two processes on one cell take turns
(the cell lock); on a local Ray instance, a 2-cell sweep gives the same table as running the
cells directly, finished cells are skipped, and a worker killed mid-cell (SIGKILL) is retried
and resumes to the result of an unbroken sweep; ``--address`` runs the same sweep on a Ray head
started by ``ray start`` in its own process. On the grasp task (robot=grasp): the grid's lattices
and leaves, the one-line refusals, and a small sweep whose rows and figure agree with an
evaluation of each cell's saved map."""

from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.cli import sweep as sweep_cli
from envs.harness.checkpoint import CHECKPOINT_FILE
from envs.harness.evaluation import evaluate
from envs.harness.run_folder import release_lock, take_lock
from envs.harness.streams import seed_env
from envs.harness.training import METRICS_FILE, RunConfig
from envs.studies.sweep_grid import (
    ATTEMPTS_FILE,
    CELL_FILE,
    LOCK_SUFFIX,
    PROGRESS_FILE,
    cell_name,
    errors_all_counted,
    expand,
    run_cell,
)
from envs.studies.sweep_plots import error_vs_neurons_figure
from learners.som.hierarchical import HierarchicalSOM

GRID = {"robot": "riacs", "lattice": [3, "4x3x2"], "trials": 1200, "eval_trials": 30}
GRID.update({"eval_every": 400})
CHECKPOINT_EVERY = 100  # trials
TIMEOUT_S = 300.0
SWEEP_SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "sweep.py"
VOLATILE = {"seconds_last_attempt"}  # wall time differs between runs


# ----------------------------------------------------------------------------- without Ray
def test_grid_expands_to_every_combination_with_parsed_values():
    configs = expand({"robot": ["riacs", "puma"], "lattice": [3, "12x7x4"], "seed": [0, "1"]})
    assert len(configs) == 8
    assert {c.env for c in configs} == {"RiacsReach-v0", "PumaReach-v0"}
    assert {c.lattice for c in configs} == {(3, 3, 3), (12, 7, 4)}
    assert {c.seed for c in configs} == {0, 1}
    assert expand({"refine": "false", "image_size": "640x480"})[0] == RunConfig.of(
        refine=False, width=640, height=480
    )
    assert len({cell_name(c) for c in configs}) == 8  # one folder per cell
    scaled = expand({"lattice": [3, 20], "trials": 1000, "trials_per_neuron": ["4"]})
    assert [c.trials for c in scaled] == [1000, 4 * 20**3]


def test_bad_grids_name_what_is_valid():
    with pytest.raises(ValueError, match="valid axes"):
        expand({"neurons": [27]})
    with pytest.raises(ValueError, match="riacs, puma"):
        expand({"robot": "kuka"})
    with pytest.raises(ValueError, match="true or false"):
        expand({"refine": "maybe"})


def test_stopped_trials_keep_their_last_distance():
    d = np.array([[3.0, 2.0, 1.0], [5.0, np.nan, np.nan], [4.0, 2.0, np.nan]])
    np.testing.assert_array_equal(
        errors_all_counted(d), [[3.0, 2.0, 1.0], [5.0, 5.0, 5.0], [4.0, 2.0, 2.0]]
    )


def test_pose_cells_take_the_pose_maps_lattices_and_count_leaves_as_neurons():
    """robot=grasp (= env=PumaGrasp-v0) trains the hierarchical map: its documented default
    lattices 8x8x6 (position) and 2x2x2 (orientation) unless the grid gives them, never the
    reach map's 12x7x4; trials_per_neuron counts leaves (position × orientation nodes)."""
    puma, grasp = expand({"robot": ["puma", "grasp"]})
    assert (puma.env, puma.lattice) == ("PumaReach-v0", (12, 7, 4))
    assert "orientation_lattice" not in puma.settings()
    assert (grasp.env, grasp.lattice, grasp.map.orientation_lattice) == (
        "PumaGrasp-v0",
        (8, 8, 6),
        (2, 2, 2),
    )
    assert expand({"env": "PumaGrasp-v0"}) == [grasp]
    assert expand({"robot": "grasp", "orientation_lattice": 2}) == [grasp]  # the same cell
    cells = expand({"robot": "grasp", "lattice": [2, "3x3x2"], "orientation_lattice": [3, "2x2x1"],
                    "trials": 100, "trials_per_neuron": 2})  # fmt: skip
    assert [(c.lattice, c.map.orientation_lattice) for c in cells] == [
        ((2, 2, 2), (3, 3, 3)), ((2, 2, 2), (2, 2, 1)),
        ((3, 3, 2), (3, 3, 3)), ((3, 3, 2), (2, 2, 1)),
    ]  # fmt: skip
    assert [c.trials for c in cells] == [2 * 8 * 27, 100, 2 * 18 * 27, 2 * 18 * 4]  # ≥ 100
    names = [cell_name(c) for c in cells]
    assert len(set(names)) == 4 and names[1].startswith("grasp_2x2x2_2x2x1_")


def test_bad_pose_grids_are_refused_in_one_line_before_anything_runs(tmp_path, capsys):
    with pytest.raises(ValueError, match="orientation_lattice is an axis of the grasp task only"):
        expand({"robot": ["puma", "grasp"], "orientation_lattice": 2})
    with pytest.raises(ValueError, match="rule=local-fit is an option of the reach map"):
        expand({"robot": "grasp", "rule": ["mrs", "local-fit"]})
    with pytest.raises(ValueError, match="lattice is written like 12x7x4"):
        expand({"robot": "grasp", "orientation_lattice": "2-2-2"})
    argv = ["--grid", "robot=riacs", "--grid", "orientation_lattice=2", "--out", str(tmp_path)]
    with pytest.raises(SystemExit) as stopped:
        sweep_cli.main(argv)
    assert stopped.value.code == 2
    message = capsys.readouterr().err.removesuffix("\n")
    assert "error: bad grid: orientation_lattice" in message and "\n" not in message
    assert "robot=grasp" in message and "RiacsReach-v0" in message
    assert not any(tmp_path.iterdir())  # nothing ran, nothing written


#: A process that runs one cell and prints its row: run_cell(RunConfig(**argv[1]), argv[2]).
RUN_CELL = """
import json, sys
from pathlib import Path
import envs
from envs.studies.sweep_grid import run_cell
from envs.harness.training import RunConfig
print(json.dumps(run_cell(RunConfig.from_stored(json.loads(sys.argv[1])), Path(sys.argv[2]), 100)))
"""


def _blocked_on(path: Path) -> int:
    """How many processes wait for the flock on ``path`` (/proc/locks: "->" lines)."""
    inode = f":{os.stat(path).st_ino} "
    lines = Path("/proc/locks").read_text().splitlines()
    return sum(1 for line in lines if "->" in line and "FLOCK" in line and inode in line)


def test_two_processes_on_one_cell_take_turns(tmp_path):
    """Two writers of one cell (two sweeps on one OUT, or a retry while the first attempt still
    runs): each waits for the cell's lock; one trains, the other finds the finished cell."""
    config = expand({**GRID, "lattice": 3, "trials": 300, "eval_trials": 10})[0]
    folder = tmp_path / "cells" / cell_name(config)
    folder.parent.mkdir(parents=True)
    lock = folder.with_name(folder.name + LOCK_SUFFIX)
    held = take_lock(lock, wait=False)  # a third writer, holding the cell while both start
    command = [sys.executable, "-c", RUN_CELL, json.dumps(config.to_stored()), str(folder)]
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    writers = [subprocess.Popen(command, stdout=subprocess.PIPE, env=env) for _ in range(2)]
    deadline = time.monotonic() + TIMEOUT_S
    while _blocked_on(lock) < 2 and time.monotonic() < deadline:
        assert all(w.poll() is None for w in writers), "a writer did not wait for the lock"
        time.sleep(0.05)
    assert _blocked_on(lock) == 2 and not folder.exists()  # both wait, nothing written yet
    release_lock(lock, held)
    rows = [json.loads(w.communicate(timeout=TIMEOUT_S)[0]) for w in writers]
    assert all(w.returncode == 0 for w in writers)
    assert rows[0] == rows[1]  # the second read the first's cell.json
    attempts = [json.loads(r) for r in (folder / ATTEMPTS_FILE).read_text().splitlines()]
    assert len(attempts) == 1 and attempts[0]["pid"] in {w.pid for w in writers}
    assert attempts[0]["start_trial"] == 0 and rows[0]["learned_trials"] > 0


# ----------------------------------------------------------------------------- on Ray
@pytest.fixture(scope="module")
def ray_local():
    ray = pytest.importorskip("ray", reason="ray not installed (make test-sweep installs it)")
    from envs.studies.sweep_on_ray import start_ray

    start_ray(None, num_cpus=2)
    yield ray
    ray.shutdown()


@pytest.fixture(scope="module")
def unbroken(ray_local, tmp_path_factory):
    from envs.studies.sweep_on_ray import run_sweep

    out = tmp_path_factory.mktemp("unbroken")
    rows = run_sweep(expand(GRID), out, checkpoint_every=CHECKPOINT_EVERY, log=lambda s: None)
    return out, rows


def _same(a: dict, b: dict) -> bool:
    return {k: v for k, v in a.items() if k not in VOLATILE} == {
        k: v for k, v in b.items() if k not in VOLATILE
    }


def test_two_cell_sweep_table_equals_running_the_cells_directly(unbroken, tmp_path):
    out, rows = unbroken
    assert len(rows) == 2
    table = json.loads((out / "results.json").read_text())
    csv_lines = (out / "results.csv").read_text().splitlines()
    assert len(csv_lines) == 3 and csv_lines[0].startswith("cell,")
    for config, row in zip(expand(GRID), table, strict=True):
        direct = run_cell(config, tmp_path / cell_name(config), CHECKPOINT_EVERY)
        assert _same(direct, row)
        assert row["eval_trials"] == config.eval_trials and len(row["mean_mm"]) == 3


def test_finished_cells_are_skipped(unbroken):
    from envs.studies.sweep_on_ray import run_sweep

    out, rows = unbroken
    lines = []
    again = run_sweep(expand(GRID), out, checkpoint_every=CHECKPOINT_EVERY, log=lines.append)
    assert "2 finished before, 0 to run" in lines[0] and again == rows


def test_worker_killed_mid_cell_is_retried_and_resumes_to_the_unbroken_result(unbroken, tmp_path):
    from envs.studies.sweep_on_ray import run_sweep

    out, rows = unbroken
    configs = expand(GRID)
    victim = tmp_path / "cells" / cell_name(configs[1])
    result: dict = {}
    sweep = threading.Thread(
        target=lambda: result.update(
            rows=run_sweep(configs, tmp_path, checkpoint_every=CHECKPOINT_EVERY, log=print)
        )
    )
    sweep.start()
    deadline = time.monotonic() + TIMEOUT_S
    while time.monotonic() < deadline:  # wait for a checkpoint past the first
        progress = victim / PROGRESS_FILE
        if progress.exists() and json.loads(progress.read_text())["trial"] >= CHECKPOINT_EVERY:
            break
        time.sleep(0.02)
    state = json.loads((victim / PROGRESS_FILE).read_text())
    assert state["trial"] < configs[1].trials, "the cell finished before it could be killed"
    os.kill(state["pid"], signal.SIGKILL)
    sweep.join(TIMEOUT_S)
    assert not sweep.is_alive()
    attempts = [json.loads(r) for r in (victim / ATTEMPTS_FILE).read_text().splitlines()]
    assert len(attempts) == 2 and attempts[0]["pid"] == state["pid"] != attempts[1]["pid"]
    assert CHECKPOINT_EVERY <= attempts[1]["start_trial"] < configs[1].trials  # resumed
    assert all(_same(a, b) for a, b in zip(result["rows"], rows, strict=True))
    unbroken_cell = out / "cells" / victim.name
    assert (victim / METRICS_FILE).read_text() == (unbroken_cell / METRICS_FILE).read_text()
    assert (victim / CELL_FILE).exists()


def test_configs_differ_only_where_the_grid_says():
    a, b = expand(GRID)
    assert replace(a, map=b.map) == b and a.settings().keys() == b.settings().keys()
    assert {k for k, v in a.settings().items() if b.settings()[k] != v} == {"lattice"}


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_address_runs_the_sweep_on_a_ray_head_of_its_own(unbroken, tmp_path):
    """``scripts/sweep.py --address``: a head started by ``ray start --head`` as a separate
    process (token authentication with a fresh token, given to head and driver), the sweep
    in another process; the rows equal the local sweep's, and every cell ran in a worker of
    that head (its worker logs name the pid of the cell's attempt). The head is stopped after."""
    rows = unbroken[1]
    ray_cli = shutil.which("ray", path=str(Path(sys.executable).parent)) or shutil.which("ray")
    assert ray_cli, "ray is importable but its command-line tool is not on the path"
    port, temp = _free_port(), Path(tempfile.mkdtemp(prefix="ray", dir="/tmp"))  # short paths
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(32)}
    env.update({"RAY_USAGE_STATS_ENABLED": "0", "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")})
    head = subprocess.Popen(
        [ray_cli, "start", "--head", "--block", f"--port={port}", "--num-cpus=2",
         "--include-dashboard=false", "--disable-usage-stats", f"--temp-dir={temp}"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + TIMEOUT_S
        while not (temp / "ray_current_cluster").exists() and time.monotonic() < deadline:
            assert head.poll() is None, head.stderr.read().decode()  # the head stopped
            time.sleep(0.1)
        grid = [f"--grid={k}={','.join(map(str, v if isinstance(v, list) else [v]))}"
                for k, v in GRID.items()]  # fmt: skip
        driver = subprocess.run(
            [sys.executable, str(SWEEP_SCRIPT), *grid, f"--out={tmp_path}",
             f"--address=127.0.0.1:{port}", f"--checkpoint-every={CHECKPOINT_EVERY}"],
            env=env, capture_output=True, text=True, timeout=TIMEOUT_S,
        )  # fmt: skip
        assert driver.returncode == 0, driver.stdout + driver.stderr
        table = json.loads((tmp_path / "results.json").read_text())
        assert all(_same(a, b) for a, b in zip(table, rows, strict=True))
        for row in table:
            attempts = (tmp_path / "cells" / row["cell"] / ATTEMPTS_FILE).read_text()
            pid = json.loads(attempts.splitlines()[0])["pid"]
            assert list(temp.glob(f"session_*/logs/worker-*-{pid}.out")), f"{pid} not the head's"
    finally:
        head.terminate()  # ray start --block stops the head's processes on SIGTERM
        try:
            head.wait(TIMEOUT_S)
        finally:
            try:
                os.killpg(head.pid, signal.SIGKILL)  # whatever of its group is left
            except ProcessLookupError:
                pass
            shutil.rmtree(temp, ignore_errors=True)


# ----------------------------------------------------------------------------- the grasp task
#: Two tiny grasp cells: 8 and 16 leaves, trials raised to 2 per leaf where above 20.
POSE_GRID = {"robot": "grasp", "lattice": 2, "orientation_lattice": [1, "2x1x1"], "trials": 20,
             "trials_per_neuron": 2, "eval_trials": 12, "eval_every": 1000}  # fmt: skip


def test_pose_sweep_rows_equal_an_evaluation_of_each_cells_saved_map(ray_local, tmp_path):
    """scripts/sweep.py on the grasp task, end to end on Ray: each row's position and
    orientation errors after every move equal those of the cell's saved map (checkpoint.npz
    loaded as a HierarchicalSOM) evaluated afresh on the same held-out env seed, its neurons are the
    leaves, and the figure's orientation panels draw the rows' mean orientation errors."""
    grid = [f"--grid={k}={','.join(map(str, v if isinstance(v, list) else [v]))}"
            for k, v in POSE_GRID.items()]  # fmt: skip
    rows = sweep_cli.main([*grid, f"--out={tmp_path}", "--checkpoint-every=10"])
    assert json.loads((tmp_path / "results.json").read_text()) == rows
    assert (tmp_path / "error_vs_neurons.png").is_file()
    assert [(r["robot"], r["neurons"], r["trials"]) for r in rows] == [
        ("grasp", 8 * 1, 20), ("grasp", 8 * 2, 32)
    ]  # fmt: skip
    for row in rows:
        som = HierarchicalSOM.load(tmp_path / "cells" / row["cell"] / CHECKPOINT_FILE)
        assert som.n_leaves == row["neurons"] and som.t == row["learned_trials"]
        env = gym.make("PumaGrasp-v0", sensing=row["sensing"], control=row["control"],
                       width=row["width"], height=row["height"])  # fmt: skip
        seed_env(env, row["seed"], "evaluation")
        try:
            result = evaluate(env, som, row["eval_trials"], row["fine_moves"])
        finally:
            env.close()
        degrees, mm = np.degrees(result.orientation_errors), result.distances * 1e3  # (n, 3)
        assert degrees.shape == (POSE_GRID["eval_trials"], 3) and np.all(np.isfinite(degrees))
        for name, stat in (("mean", np.mean), ("median", np.median)):
            np.testing.assert_allclose(row[f"{name}_deg"], stat(degrees, axis=0), atol=1e-5)
            np.testing.assert_allclose(row[f"{name}_mm"], stat(mm, axis=0), atol=1e-5)
        np.testing.assert_allclose(row["p90_deg"], np.percentile(degrees, 90, axis=0), atol=1e-5)
        assert row["mean_deg"][2] < row["mean_deg"][0]  # the fine moves turn the hand closer
    panels = [ax for ax in error_vs_neurons_figure(rows).axes if "orientation" in ax.get_ylabel()]
    assert len(panels) == 3  # one per move
    for move, ax in enumerate(panels):
        line = next(li for li in ax.get_lines() if li.get_label().startswith("robot=grasp"))
        np.testing.assert_array_equal(line.get_xdata(), [8, 16])
        np.testing.assert_allclose(line.get_ydata(), [r["mean_deg"][move] for r in rows])
