"""Writing where it cannot go, under real conditions: a read-only folder and a full disk (small
tmpfs mounts in a private mount namespace, so nothing outlives the test). train, evaluate and
video say so in one line naming the path and the cause (exit 2) before any work, leave no empty
``run.lock``, and a checkpoint survives a save that ran out of space."""

from __future__ import annotations

import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
TINY = ["--trials", "20", "--lattice", "3x2x2", "--eval-every", "10", "--eval-trials", "3"]
#: Size of the test's tmpfs: room for a tiny run (about 12 KiB) and little more.
TMPFS_SIZE = "64k"


def _script(name: str, *args: object) -> str:
    return shlex.join([sys.executable, str(SCRIPTS / f"{name}.py"), *map(str, args)])


def _in_private_mounts(shell: str) -> subprocess.CompletedProcess:
    """Run ``shell`` (sh) in a mount namespace of its own: its mounts vanish with it."""
    command = ["unshare", "--mount", "--propagation", "private", "sh", "-c", shell]
    return subprocess.run(command, capture_output=True, text=True, check=False)


@pytest.fixture(scope="module")
def mounts(tmp_path_factory) -> None:
    """Skip (saying why) where tmpfs cannot be mounted in a private namespace."""
    if shutil.which("unshare") is None:
        pytest.skip("unshare (util-linux) is not installed")
    probe = tmp_path_factory.mktemp("probe")
    result = _in_private_mounts(f"mount -t tmpfs -o size={TMPFS_SIZE} tmpfs {probe}")
    if result.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs in a private namespace: {result.stderr.strip()}")


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run")
    result = subprocess.run(
        [sys.executable, str(SCRIPTS / "train.py"), *TINY, "--out", str(out)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return out


def _one_line_error(stderr: str) -> str:
    lines = [line for line in stderr.splitlines() if "error:" in line]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def _results(stdout: str) -> list[str]:
    """Lines the shell script marked ``result:`` (exit statuses, listings)."""
    return [line.removeprefix("result:") for line in stdout.splitlines() if "result:" in line]


@pytest.mark.parametrize("script", ["train", "evaluate", "video"])
def test_a_read_only_folder_is_one_line_before_any_work(script, mounts, run, tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    command = {
        "train": _script("train", *TINY, "--out", folder / "t"),
        "evaluate": _script("evaluate", "--run", run, "--targets", "3", "--out", folder / "e"),
        "video": _script("video", "--controller", "random", "--out", folder / "v.mp4"),
    }[script]
    result = _in_private_mounts(
        f"mount -t tmpfs -o ro,size={TMPFS_SIZE} tmpfs {folder} && {command}; "
        f"echo result:$?; echo result:$(ls -A {folder})"
    )
    status, listing = _results(result.stdout)
    assert status == "2", result.stderr
    line = _one_line_error(result.stderr)
    assert str(folder) in line and "Read-only file system" in line
    assert listing == ""
    assert "targets, seed" not in result.stdout  # evaluate printed no table: no work was done


def _fill(folder: Path, pages_left: int) -> str:
    """Shell that fills the file system of ``folder`` up to ``pages_left`` free 4 KiB pages."""
    return (
        f"free=$(stat -f -c %a {folder}); "
        f"dd if=/dev/zero of={folder}/fill bs=4096 count=$((free - {pages_left})) 2>/dev/null; "
    )


def test_a_full_disk_is_one_line_and_leaves_no_lock(mounts, run, tmp_path):
    folder = tmp_path / "full"
    folder.mkdir()
    train = _script("train", *TINY, "--out", folder / "t")
    evaluate = _script("evaluate", "--run", run, "--targets", "3", "--out", folder / "e")
    result = _in_private_mounts(
        f"mount -t tmpfs -o size={TMPFS_SIZE} tmpfs {folder} && mkdir {folder}/t && "
        + _fill(folder, 0)
        + f"{train}; echo result:$?; echo result:$(ls -A {folder}/t); "
        f"{evaluate}; echo result:$?"
    )
    train_status, listing, evaluate_status = _results(result.stdout)
    assert (train_status, listing, evaluate_status) == ("2", "", "2"), result.stderr
    lines = [line for line in result.stderr.splitlines() if "error:" in line]
    assert len(lines) == 2 and "Traceback" not in result.stderr, result.stderr
    assert f"{folder}/t/run.lock: cannot write (No space left on device)" in lines[0]
    assert f"{folder}/e: cannot write (No space left on device)" in lines[1]


def test_a_save_that_runs_out_of_space_keeps_the_checkpoint(mounts, run, tmp_path):
    """Room for the lock and the metrics rows, not for a second checkpoint beside the first:
    the extended run stops at its first save with one line; the checkpoint is the old one,
    and once space is freed ``--resume`` finishes the run."""
    folder = tmp_path / "tight"
    folder.mkdir()
    before = (run / "checkpoint.npz").read_bytes()
    resume = _script("train", "--out", folder / "t", "--resume", "--trials", "40")
    result = _in_private_mounts(
        f"mount -t tmpfs -o size={TMPFS_SIZE} tmpfs {folder} && cp -r {run} {folder}/t && "
        + _fill(folder, 1)
        + f"{resume} --checkpoint-every 1; echo result:$?; "
        f"cmp {folder}/t/checkpoint.npz {run}/checkpoint.npz && echo result:same; "
        f"echo result:$(ls -A {folder}/t); rm {folder}/fill; {resume}; echo result:$?"
    )
    status, same, listing, resumed = _results(result.stdout)
    assert status == "2", result.stderr
    assert "checkpoint.npz: cannot write (No space left on device)" in result.stderr
    assert same == "same" and (run / "checkpoint.npz").read_bytes() == before
    assert listing == "checkpoint.npz metrics.jsonl"  # no lock, no temporary file
    assert resumed == "0", result.stderr
    assert "trained 40 trials" in result.stdout
