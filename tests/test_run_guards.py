"""Guarded run folders and checkpoint identity, through the real scripts in real processes:
one writer per folder, no fresh run over an old one, --resume refuses changed settings, and a
checkpoint of another arm or lattice is refused by resume, evaluate and video."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

from helpers import SCRIPTS, one_line_error, run_script

#: s: a run starts in seconds on an idle machine; only a hang comes near this on a loaded one.
HANG_TIMEOUT = 300.0
TINY = ["--trials", "20", "--lattice", "3x2x2", "--eval-every", "10", "--eval-trials", "3"]


@pytest.fixture(scope="module")
def puma_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("puma")
    assert run_script("train", "--env", "PumaReach-v0", *TINY, "--out", str(out)).returncode == 0
    return out


def test_a_second_writer_is_refused_and_the_first_stops_cleanly_on_sigterm(tmp_path):
    first = subprocess.Popen(
        [sys.executable, str(SCRIPTS / "train.py"), "--trials", "1000000", "--eval-every",
         "100000", "--eval-trials", "3", "--out", str(tmp_path)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + HANG_TIMEOUT
        while not (tmp_path / "checkpoint.npz").exists():
            if time.monotonic() > deadline or first.poll() is not None:
                pytest.fail(
                    f"the first run wrote no checkpoint.npz in {HANG_TIMEOUT:.0f} s (or ended)"
                )
            time.sleep(0.05)
        second = run_script("train", "--out", str(tmp_path), "--resume")
        assert f"in use by process {first.pid}" in one_line_error(second)
        forced = run_script("train", "--out", str(tmp_path), "--force")
        assert f"in use by process {first.pid}" in one_line_error(forced)
    finally:
        first.send_signal(signal.SIGTERM)
        out, _ = first.communicate(timeout=HANG_TIMEOUT)
    assert first.returncode == 143 and "stopped by SIGTERM" in out
    assert not (tmp_path / "run.lock").exists()


def test_a_fresh_run_into_a_used_folder_refuses_and_leaves_it_unchanged(puma_run):
    before = {p.name: p.read_bytes() for p in puma_run.iterdir() if p.is_file()}
    line = one_line_error(run_script("train", *TINY, "--out", str(puma_run)))
    assert "already holds a run" in line and "--force" in line
    assert {p.name: p.read_bytes() for p in puma_run.iterdir() if p.is_file()} == before


def test_resume_names_the_settings_that_may_not_change(puma_run):
    line = one_line_error(
        run_script("train", "--out", str(puma_run), "--resume", "--env", "RiacsReach-v0",
                "--lattice", "4x4x4")
    )  # fmt: skip
    assert "--env RiacsReach-v0 (the run has PumaReach-v0)" in line
    assert "--lattice 4x4x4 (the run has 3x2x2)" in line
    # a map option is shown as its flag spells it, not as the checkpoint stores it ("brause")
    line = one_line_error(
        run_script("train", "--out", str(puma_run), "--resume", "--theta-target", "fine-error")
    )
    assert "--theta-target fine-error (the run has coarse-error)" in line
    assert "only --trials and --checkpoint-every may change" in line


def test_a_foreign_checkpoint_is_refused_by_resume_evaluate_and_video(puma_run, tmp_path):
    riacs = tmp_path / "riacs"
    assert run_script("train", *TINY, "--out", str(riacs)).returncode == 0
    (riacs / "checkpoint.npz").write_bytes(
        (puma_run / "checkpoint.npz").read_bytes()
    )  # copied over
    line = one_line_error(run_script("train", "--out", str(riacs), "--resume", "--env",
                                   "RiacsReach-v0"))  # fmt: skip
    assert "RiacsReach-v0 (the run has PumaReach-v0)" in line
    unit = str(puma_run / "checkpoint.npz")
    line = one_line_error(run_script("evaluate", "--controller", unit, "--env", "RiacsReach-v0",
                                   "--targets", "3", "--out", str(tmp_path / "e")))  # fmt: skip
    assert "robot='puma560'" in line and "robot='riacs'" in line
    line = one_line_error(run_script("video", "--controller", unit, "--env", "RiacsReach-v0",
                                   "--trials", "1", "--out", str(tmp_path / "v.mp4")))  # fmt: skip
    assert "robot='puma560'" in line and "robot='riacs'" in line
    assert not (tmp_path / "e").exists() and not (tmp_path / "v.mp4").exists()


def test_a_pose_only_option_on_a_reach_map_is_a_one_line_error(puma_run, tmp_path):
    line = one_line_error(run_script("evaluate", "--run", str(puma_run), "--no-backtrack",
                                   "--targets", "2", "--out", str(tmp_path / "e")))  # fmt: skip
    assert (
        "--no-backtrack and --trust-radius change the hierarchical map of PumaGrasp-v0 only" in line
    )


def test_resume_keeps_the_runs_checkpoint_every_unless_it_is_given_again(tmp_path):
    """train.py --resume used to fall back to --checkpoint-every's default (1000)."""
    from envs.harness.checkpoint import read_unit

    def stored():
        return read_unit(tmp_path / "checkpoint.npz")[0]["checkpoint_every"]

    short = ["--lattice", "3x2x2", "--eval-every", "4", "--eval-trials", "3"]
    first = run_script("train", "--trials", "4", *short, "--checkpoint-every", "3",
                       "--out", str(tmp_path))  # fmt: skip
    assert first.returncode == 0, first.stderr
    assert stored() == 3
    resumed = run_script("train", "--out", str(tmp_path), "--resume", "--trials", "8")
    assert resumed.returncode == 0, resumed.stderr
    assert stored() == 3
    again = run_script("train", "--out", str(tmp_path), "--resume", "--trials", "12",
                       "--checkpoint-every", "5")  # fmt: skip
    assert again.returncode == 0, again.stderr
    assert stored() == 5
