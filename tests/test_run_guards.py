"""Guarded run folders and checkpoint identity, through the real scripts in real processes:
one writer per folder, no fresh run over an old one, --resume refuses changed settings, and a
checkpoint of another arm or lattice is refused by resume, evaluate and video."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
TINY = ["--trials", "20", "--lattice", "3x2x2", "--eval-every", "10", "--eval-trials", "3"]


def _script(name: str, *args: str) -> subprocess.CompletedProcess:
    command = [sys.executable, str(SCRIPTS / f"{name}.py"), *args]
    return subprocess.run(command, capture_output=True, text=True, check=False)


@pytest.fixture(scope="module")
def puma_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("puma")
    assert _script("train", "--env", "PumaReach-v0", *TINY, "--out", str(out)).returncode == 0
    return out


def _one_line_error(result: subprocess.CompletedProcess) -> str:
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.splitlines() if "error:" in line]
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


def test_a_second_writer_is_refused_and_the_first_stops_cleanly_on_sigterm(tmp_path):
    first = subprocess.Popen(
        [sys.executable, str(SCRIPTS / "train.py"), "--trials", "1000000", "--eval-every",
         "100000", "--eval-trials", "3", "--out", str(tmp_path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        deadline = time.time() + 60
        while not (tmp_path / "som.npz").exists() and time.time() < deadline:
            time.sleep(0.05)
        second = _script("train", "--out", str(tmp_path), "--resume")
        assert f"in use by process {first.pid}" in _one_line_error(second)
        forced = _script("train", "--out", str(tmp_path), "--force")
        assert f"in use by process {first.pid}" in _one_line_error(forced)
    finally:
        first.send_signal(signal.SIGTERM)
        out, _ = first.communicate(timeout=60)
    assert first.returncode == 143 and "stopped by SIGTERM" in out
    assert not (tmp_path / "run.lock").exists()


def test_a_fresh_run_into_a_used_folder_refuses_and_leaves_it_unchanged(puma_run):
    before = {p.name: p.read_bytes() for p in puma_run.iterdir() if p.is_file()}
    line = _one_line_error(_script("train", *TINY, "--out", str(puma_run)))
    assert "already holds a run" in line and "--force" in line
    assert {p.name: p.read_bytes() for p in puma_run.iterdir() if p.is_file()} == before


def test_resume_names_the_settings_that_may_not_change(puma_run):
    line = _one_line_error(
        _script("train", "--out", str(puma_run), "--resume", "--env", "RiacsReach-v0",
                "--lattice", "4x4x4")
    )  # fmt: skip
    assert "--env RiacsReach-v0 (the run has PumaReach-v0)" in line
    assert "--lattice 4x4x4 (the run has 3x2x2)" in line
    assert "only --trials and --checkpoint-every may change" in line


def test_a_foreign_checkpoint_is_refused_by_resume_evaluate_and_video(puma_run, tmp_path):
    riacs = tmp_path / "riacs"
    assert _script("train", *TINY, "--out", str(riacs)).returncode == 0
    (riacs / "som.npz").write_bytes((puma_run / "som.npz").read_bytes())  # copied over
    line = _one_line_error(_script("train", "--out", str(riacs), "--resume", "--env",
                                   "RiacsReach-v0"))  # fmt: skip
    assert "RiacsReach-v0 (the run has PumaReach-v0)" in line
    unit = str(puma_run / "som.npz")
    line = _one_line_error(_script("evaluate", "--controller", unit, "--env", "RiacsReach-v0",
                                   "--targets", "3", "--out", str(tmp_path / "e")))  # fmt: skip
    assert "robot='puma560'" in line and "robot='riacs'" in line
    line = _one_line_error(_script("video", "--controller", unit, "--env", "RiacsReach-v0",
                                   "--trials", "1", "--out", str(tmp_path / "v.mp4")))  # fmt: skip
    assert "robot='puma560'" in line and "robot='riacs'" in line
    assert not (tmp_path / "e").exists() and not (tmp_path / "v.mp4").exists()
