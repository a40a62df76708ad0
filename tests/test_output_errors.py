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
#: Room for an old video and a few pages; the new video (some 100 KiB) does not fit.
VIDEO_TMPFS_SIZE = "256k"
#: Room for a tiny run and its evaluation's figures (about 400 KiB).
EVAL_TMPFS_SIZE = "2m"


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
    assert f"{folder}/t: cannot write (No space left on device)" in lines[0]
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
    line = _error_line(result.stderr, "train.py")  # on its own line, after the progress bar
    assert "checkpoint.npz: cannot write (No space left on device)" in line
    assert same == "same" and (run / "checkpoint.npz").read_bytes() == before
    assert listing == "checkpoint.npz metrics.jsonl"  # no lock, no temporary file
    assert resumed == "0", result.stderr
    assert "trained 40 trials" in result.stdout


def test_a_fresh_run_onto_a_full_disk_leaves_no_folder(mounts, tmp_path):
    folder = tmp_path / "full"
    folder.mkdir()
    train = _script("train", *TINY, "--out", folder / "new" / "t")
    result = _in_private_mounts(
        f"mount -t tmpfs -o size={TMPFS_SIZE} tmpfs {folder} && "
        + _fill(folder, 0)
        + f"{train}; echo result:$?; echo result:$(ls -A {folder})"
    )
    assert _results(result.stdout) == ["2", "fill"], result.stderr
    assert "cannot write (No space left on device)" in _error_line(result.stderr, "train.py")


def _error_line(stderr: str, program: str) -> str:
    """The one error line of ``stderr``, which must start a line of its own (after a progress
    bar only the carriage returns and blanks that clear it may precede it); no traceback."""
    lines = [line for line in stderr.split("\n") if "error:" in line]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    before, said, rest = lines[0].partition(f"{program}: error: ")
    assert said and before.strip("\r ") == "", repr(lines[0][:300])
    return rest


def _listing(folder: Path) -> str:
    """Shell that prints ``result:`` and the names in ``folder``, and one more ``result:`` line
    per file with its checksum."""
    return f"echo result:$(ls -A {folder}); echo result:$(cd {folder} && cksum * | sort -k3); "


def test_a_video_that_fills_the_disk_is_one_line_and_keeps_nothing_half_written(mounts, tmp_path):
    """ffmpeg runs out of space while it encodes: one line, exit 2, no file under the video's
    name and no ``.partial``; an older video of that name and other files are left as they
    were."""
    folder = tmp_path / "video"
    folder.mkdir()
    video = _script(
        "video", "--env", "RiacsReach-v0", "--controller", "random", "--sensing", "project",
        "--control", "kinematic", "--trials", "3", "--out", folder / "v.mp4",
    )  # fmt: skip
    result = _in_private_mounts(
        f"mount -t tmpfs -o size={VIDEO_TMPFS_SIZE} tmpfs {folder} && "
        f"head -c 5000 /dev/urandom > {folder}/v.mp4 && echo kept > {folder}/notes.txt && "
        + _listing(folder)
        + _fill(folder, 4)
        + f"{video}; echo result:$?; rm {folder}/fill; "
        + _listing(folder)
    )
    names_before, sums_before, status, names_after, sums_after = _results(result.stdout)
    assert status == "2", result.stderr
    line = _error_line(result.stderr, "video.py")
    assert f"{folder}/v.mp4: video not written" in line, line
    assert names_after == names_before == "notes.txt v.mp4"  # no v.mp4.partial
    assert _sums(sums_after) == _sums(sums_before)  # the old v.mp4 is untouched
    assert "wrote" not in result.stdout


#: Controllers enough for an evaluation.json of two 4 KiB pages (one is some 640 bytes).
MANY = ["--compare", *["analytic", "jacobian", "random"] * 3]


@pytest.mark.parametrize("part", ["figures", "table"])
def test_plots_or_json_that_fill_the_disk_are_one_line_and_keep_nothing_half_written(
    part, mounts, run, tmp_path
):
    """evaluate.py, again over an earlier evaluation, with one free page: room for the table
    (evaluation.json) but not for the figures, or with a table too large for it. One line,
    exit 2; no temporary and no torn file: the files not rewritten are byte for byte the
    earlier ones, a rewritten table is whole."""
    folder = tmp_path / "eval"
    folder.mkdir()
    evaluate = _script("evaluate", "--run", folder / "run", "--targets", "3")
    again = evaluate + (" " + shlex.join(MANY) if part == "table" else "")
    result = _in_private_mounts(
        f"mount -t tmpfs -o size={EVAL_TMPFS_SIZE} tmpfs {folder} && cp -r {run} {folder}/run && "
        f"{evaluate} > /dev/null && "
        + _listing(f"{folder}/run/eval")
        + _fill(folder, 1)
        + f"{again}; echo result:$?; "
        + _listing(f"{folder}/run/eval")
        + f"python3 -m json.tool {folder}/run/eval/evaluation.json > /dev/null; echo result:$?"
    )
    names_before, sums_before, status, names_after, sums_after, json_ok = _results(result.stdout)
    assert status == "2", result.stderr
    line = _error_line(result.stderr, "evaluate.py")
    written = "run/learning_curve.png" if part == "figures" else "run/eval/evaluation.json"
    assert f"{written}: cannot write (No space left on device)" in line, line
    assert names_after == names_before  # every figure is there, no temporary beside them
    changed = {n for n, sum_ in _sums(sums_after).items() if _sums(sums_before)[n] != sum_}
    assert changed == ({"evaluation.json"} if part == "figures" else set()), changed
    assert json_ok == "0"


def _sums(listing: str) -> dict[str, tuple[str, str]]:
    """File name -> (checksum, size) of a ``cksum`` listing joined on one line."""
    words = listing.split()
    return {words[k + 2]: (words[k], words[k + 1]) for k in range(0, len(words), 3)}
