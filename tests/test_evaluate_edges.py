"""Edges a user of evaluate.py and train.py meets: ``--run`` given as a folder, its checkpoint or
something else (messages that fit evaluate, before any work), a metrics log with a torn last
line (left out with one note, as ``--resume`` does), and progress bars that say what runs."""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from envs.cli.controllers import make_controller, run_folder
from envs.cli.evaluate import evaluate_with_bar
from envs.harness.evaluation import Ticking, evaluate
from envs.harness.run_folder import read_metrics, truncate_metrics
from learners.persistence import CheckpointError
from learners.som.controller import VisuomotorSOM

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
TINY = ["--trials", "20", "--lattice", "3x2x2", "--eval-every", "10", "--eval-trials", "3"]
ROWS = [{"trial": 0, "mean_mm": [1.5, 0.25]}, {"trial": 10, "mean_mm": [0.75, 0.125]}]


def _script(name: str, *args: object) -> subprocess.CompletedProcess:
    command = [sys.executable, str(SCRIPTS / f"{name}.py"), *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, check=False)


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> tuple[Path, str]:
    """A tiny run and train.py's stderr (its progress bar)."""
    out = tmp_path_factory.mktemp("run")
    result = _script("train", *TINY, "--out", out)
    assert result.returncode == 0, result.stderr
    return out, result.stderr


def _one_line_error(result: subprocess.CompletedProcess) -> str:
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.splitlines() if "error:" in line]
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


def _log(path: Path, rows: list[dict], tail: bytes = b"") -> Path:
    path.write_bytes(b"".join(json.dumps(r).encode() + b"\n" for r in rows) + tail)
    return path


# -- --run ---------------------------------------------------------------------------------------


def test_run_is_a_folder_or_its_checkpoint(tmp_path):
    (tmp_path / "checkpoint.npz").write_bytes(b"")
    (tmp_path / "map.npz").write_bytes(b"")
    (tmp_path / "empty").mkdir()
    assert run_folder(str(tmp_path)) == tmp_path
    assert run_folder(str(tmp_path / "checkpoint.npz")) == tmp_path
    wrong = {
        "missing": "does not exist; pass the --out folder of a train.py run",
        "empty": "holds no checkpoint.npz, so no train.py run",
        "map.npz": "is a file, not a train.py run folder; pass the run's folder (or its "
        "checkpoint.npz), or evaluate this map with --controller",
    }
    for name, message in wrong.items():
        with pytest.raises(argparse.ArgumentTypeError, match=re.escape(message)):
            run_folder(str(tmp_path / name))


def test_evaluate_without_a_run_says_so_without_resume_and_writes_nothing(tmp_path):
    result = _script("evaluate", "--run", tmp_path / "riacs", "--out", tmp_path / "e")
    line = _one_line_error(result)
    assert f"{tmp_path / 'riacs'} does not exist" in line and "resume" not in line
    assert list(tmp_path.iterdir()) == []


def test_a_plain_map_as_run_points_to_controller(trained, tmp_path):
    plain = tmp_path / "checkpoint.npz"
    VisuomotorSOM.load(trained[0] / "checkpoint.npz").save(plain)  # the map alone, no run state
    line = _one_line_error(_script("evaluate", "--run", plain, "--out", tmp_path / "e"))
    assert f"evaluate it with --controller {plain}" in line and "resume" not in line
    assert not (tmp_path / "e").exists()


def test_compare_takes_a_run_folder_and_refuses_a_bad_one_in_one_line(trained, tmp_path):
    """``--compare RUN`` is the run's map: the same map twice gives the same row twice."""
    run = trained[0]
    args = ["--run", run, "--targets", "3", "--fine-moves", "1", "--no-plots"]
    result = _script("evaluate", *args, "--compare", run, "--out", tmp_path / "e")
    assert result.returncode == 0, result.stderr
    rows = [line.split() for line in result.stdout.splitlines() if "mrs+" in line]
    # the same errors and completion; the column before the last is time per query
    assert len(rows) == 2 and rows[0][:-2] + rows[0][-1:] == rows[1][:-2] + rows[1][-1:]
    for bad, message in (("nonsense", "got 'nonsense'"), (tmp_path / "no", "does not exist")):
        line = _one_line_error(_script("evaluate", *args, "--compare", bad))
        assert "argument --compare" in line and message in line


# -- the metrics log -----------------------------------------------------------------------------


def test_read_metrics_leaves_out_a_torn_last_line_and_says_so_once(tmp_path):
    notes: list[str] = []
    assert read_metrics(_log(tmp_path / "m.jsonl", ROWS), notes.append) == ROWS
    assert notes == []
    torn = _log(tmp_path / "t.jsonl", ROWS, b'{"trial": 20, "mean')
    assert read_metrics(torn, notes.append) == ROWS
    assert len(notes) == 1 and str(torn) in notes[0] and "torn last line" in notes[0]


def test_read_metrics_refuses_a_damaged_row_before_the_last(tmp_path):
    path = tmp_path / "m.jsonl"
    path.write_bytes(b'{"trial": 0}\n{"tri\n{"trial": 20}\n')
    with pytest.raises(CheckpointError, match="row 2 of 3 is unreadable"):
        read_metrics(path, lambda note: None)


def test_truncate_metrics_agrees_with_the_reader(tmp_path):
    """What ``--resume`` keeps of a torn log is what the reader reads."""
    path = _log(tmp_path / "m.jsonl", ROWS, b'{"trial": 20, "mean')
    truncate_metrics(path, len(ROWS))
    assert path.read_bytes() == b"".join(json.dumps(r).encode() + b"\n" for r in ROWS)
    assert read_metrics(path, pytest.fail) == ROWS
    with pytest.raises(CheckpointError, match="2 readable rows, the checkpoint counts 3"):
        truncate_metrics(path, 3)


def test_evaluate_a_run_with_a_torn_log_given_as_its_checkpoint(trained, tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    for name in ("checkpoint.npz", "metrics.jsonl"):
        (run / name).write_bytes((trained[0] / name).read_bytes())
    with open(run / "metrics.jsonl", "ab") as f:
        f.write(b'{"trial": 30, "learned')  # what a kill leaves
    result = _script(
        "evaluate", "--run", run / "checkpoint.npz", "--targets", "3", "--out", tmp_path / "e"
    )
    assert result.returncode == 0, result.stderr
    notes = [line for line in result.stderr.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and "torn last line" in notes[0], result.stderr
    summary = json.loads((tmp_path / "e" / "evaluation.json").read_text())
    assert summary["controllers"][0]["trials"] == 3
    assert (run / "learning_curve.png").stat().st_size > 0  # the training's curve: in the run


# -- progress ------------------------------------------------------------------------------------


def test_the_evaluation_bar_ticks_once_per_target_and_changes_no_number():
    env = gym.make("RiacsReach-v0", sensing="project", control="kinematic")
    ticks: list[int] = []
    env.reset(seed=3)
    counted = evaluate(env, Ticking(make_controller("random", env, 1), lambda: ticks.append(1)), 7)
    assert len(ticks) == 7
    env.reset(seed=3)
    plain = evaluate(env, make_controller("random", env, 1), 7)
    env.reset(seed=3)
    barred = evaluate_with_bar(env, make_controller("random", env, 1), "random", 7, 2)
    env.close()
    for result in (counted, barred):
        np.testing.assert_array_equal(result.distances, plain.distances)
        np.testing.assert_array_equal(result.reached, plain.reached)


def test_the_training_bar_says_when_it_evaluates(trained):
    stderr = trained[1].replace("\r", "\n")
    lines = [line for line in stderr.splitlines() if "/20 [" in line]
    assert lines[0].startswith("train: held-out evaluation (3 targets):")
    assert " 0/20 [" in lines[0]  # before the first trial: the untrained map's evaluation
    assert any(line.startswith("train:  ") and "11/20" in line for line in lines)
    assert lines[-1].startswith("train: 100%")
