"""Every command-line mistake is one short line, found before any work, and creates nothing: a
table of bad inputs for every program in scripts/ that takes an output path or counts (an
output folder that is a file, a parent that is a file, a file name that is a folder, counts of
0, negative, absurd and of 5 000 digits, absurd lattices), each in a real process. And Ctrl-C
at a moment drawn at random in a program's first seconds (imports, env creation, the first
evaluation) is one line and exit status 130, never a traceback."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from helpers import SCRIPTS, one_line_error, run_script

#: program -> (arguments it needs, its output option and whether that is a folder or a file,
#: its count options). Counts that may be 0 are in ``ZERO_ALLOWED``.
PROGRAMS: dict[str, tuple[list[str], tuple[str, str] | None, list[str]]] = {
    "train": ([], ("--out", "folder"), ["--trials", "--eval-trials", "--eval-every"]),
    "evaluate": (["--controller", "analytic"], ("--out", "folder"), ["--targets", "--fine-moves"]),
    "video": (["--controller", "random"], ("--out", "file"), ["--trials", "--fine-moves"]),
    "demo": ([], ("--out", "folder"), ["--trials", "--targets"]),
    "adapt": ([], ("--out", "folder"), ["--eval-trials", "--after", "--video-trials"]),
    "bench_natenet": ([], ("--out", "folder"), ["--nodes", "--queries"]),
    "bench_som": ([], ("--out", "folder"), ["--trials", "--batch"]),
    "bench_workers": ([], ("--out", "folder"), ["--trials", "--targets"]),
    "compare_rl": ([], ("--out", "folder"), ["--budget", "--targets"]),
    "docs_media": ([], ("--out", "folder"), ["--trials"]),
    "grasp_learning": ([], ("--out", "file"), ["--targets", "--fine-moves"]),
    "accuracy": ([], ("--out", "folder"), []),
    "redundancy": (["--run", "folder"], ("--out", "folder"), ["--targets", "--fine-moves"]),
    "reproduce_brause": ([], ("--out", "folder"), ["--points"]),
    "riacs_dataset": ([], ("--out", "folder"), ["--train", "--test"]),
    "sweep": (["--grid", "robot=riacs"], ("--out", "folder"), ["--num-cpus", "--retries"]),
    "train_natenet": ([], ("--out", "folder"), ["--train-paths", "--test-paths"]),
    "sensing_accuracy": ([], ("--json", "file"), ["--poses"]),
    "framing": ([], ("--json", "file"), ["--moves", "--pixel-moves"]),
    "bench_envs": ([], ("--json", "file"), ["--steps"]),
    "bench_trials": ([], ("--json", "file"), ["--trials", "--block"]),
    "bench_ik": ([], None, ["--single", "--batch"]),
    "make_arm": ([str(SCRIPTS.parent / "models" / "ur5e" / "dh.toml")], ("--out", "folder"), []),
}
ZERO_ALLOWED = {"--fine-moves", "--video-trials", "--retries"}
#: Lattice options (with what they need), and lattices no memory holds or no map has.
LATTICES = [
    ("train", ["--lattice"]),
    ("train", ["--env", "PumaGrasp-v0", "--orientation-lattice"]),
    ("bench_som", ["--lattice"]),
    ("bench_som", ["--big"]),
]
BAD_LATTICES = ["100000x100000x100000", "0x2x2", "3x"]
#: Mistakes of one program's own: a grid file that does not parse or is missing, a pose of the
#: wrong length.
OTHER_MISTAKES = [
    ("sweep", ["--spec", "file"], "--spec file"),
    ("sweep", ["--spec", "missing.json"], "--spec missing.json"),
    ("accuracy", ["--pose", "1", "2"], "--pose"),
]
ABSURD = str(10**12)
#: s after which a program given a mistake is taken to have started work (TimeoutExpired).
WORK = 120
#: Characters of the longest line a mistake may print.
MAX_LINE = 200
DIGITS = "9" * 5000  # more digits than Python converts to int by default


def _cases() -> list[tuple[str, list[str], str]]:
    """(program, arguments, what the line must name) for every bad input."""
    cases = []
    for name, (needs, out, counts) in PROGRAMS.items():
        if out is not None:
            flag, kind = out
            bad = ["file", "file/sub"] if kind == "folder" else ["folder", "file/out.mp4"]
            cases += [(name, [*needs, flag, path], path) for path in bad]
        for flag in counts:
            values = ["-3", ABSURD, DIGITS] + ([] if flag in ZERO_ALLOWED else ["0"])
            cases += [(name, [*needs, flag, value], flag) for value in values]
    cases += [(name, [*flag, bad], flag[-1]) for name, flag in LATTICES for bad in BAD_LATTICES]
    memory = ["--controller", "analytic", "--targets", "1000000", "--fine-moves", "1000"]
    cases.append(("evaluate", memory, "--fine-moves"))  # each bounded, the product is not
    cases += OTHER_MISTAKES
    return cases


CASES = _cases()


@pytest.mark.parametrize(("name", "args", "named"), CASES, ids=[
    f"{n}:{' '.join(a)[-40:]}" for n, a, _ in CASES])  # fmt: skip
def test_a_mistake_is_one_short_line_with_status_2_and_creates_nothing(name, args, named, tmp_path):
    (tmp_path / "file").write_text("not a folder")
    (tmp_path / "folder").mkdir()
    result = run_script(name, *args, cwd=tmp_path, timeout=WORK)  # a mistake stops at once
    line = one_line_error(result)  # exit 2, no traceback, one line saying "error:"
    assert len(line) <= MAX_LINE, line
    assert named in line, line
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["file", "folder"]  # nothing made
    assert (tmp_path / "file").read_text() == "not a folder"


def test_the_table_covers_every_program_with_an_output_or_a_count():
    """A program added to scripts/ with --out, --json or a count joins the table."""
    import re

    missing = []
    for path in sorted(SCRIPTS.glob("[!_]*.py")):
        text = run_script(path.stem, "--help").stdout
        takes = re.search(r"^  --(out|json|trials|targets|fine-moves) ", text, re.M)
        if takes and path.stem not in PROGRAMS:
            missing.append(path.stem)
    assert missing == []


# ---- Ctrl-C at start-up

#: Programs interrupted, each with work that lasts well beyond the signal.
INTERRUPTED = {
    "train": ["--trials", "100000", "--lattice", "3x2x2", "--eval-trials", "50"],
    "evaluate": ["--env", "RiacsReach-v0", "--controller", "analytic", "--targets", "100000"],
    "video": ["--env", "RiacsReach-v0", "--controller", "analytic", "--trials", "1000"],
}
SIGNALS_PER_PROGRAM = 8
#: s after the program's own imports began within which the moments fall (imports, the env,
#: the run folder, the first evaluation).
START_UP = 3.0
BAR = ("%|", "trial/s", "target/s")


def _importing(process: subprocess.Popen) -> bool:
    """Wait until ``process`` maps numpy (the interpreter has started and runs the program's
    imports; before, Python itself reports a Ctrl-C while it imports its site module, out of the
    program's reach); False if it ended first."""
    maps = Path(f"/proc/{process.pid}/maps")
    while process.poll() is None:
        try:
            if "numpy" in maps.read_text():
                return True
        except OSError:
            pass
        time.sleep(0.002)
    return False


#: A program whose Ctrl-C a library turns into a user error (as a GL start cut short may):
#: SIGINT to itself (its argument ``interrupted``), then the error.
TURNED = """
import os, signal, sys, time
from envs.cli import common
from envs.sensing.rendering import RenderingUnavailableError

def main():
    try:
        if sys.argv[1] == "interrupted":
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(60)
    except KeyboardInterrupt:
        pass
    raise RenderingUnavailableError("could not start MUJOCO_GL=egl")

common.run(main)
"""


@pytest.mark.parametrize(
    ("case", "status", "said"),
    [("interrupted", 130, "interrupted (Ctrl-C)"), ("plain", 2, "error: could not start")],
)
def test_an_error_a_library_made_of_ctrl_c_is_the_interrupt(case, status, said):
    result = subprocess.run([sys.executable, "-c", TURNED, case], capture_output=True,
                            text=True, timeout=120)  # fmt: skip
    assert result.returncode == status, result.stderr[-2000:]
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and said in lines[0], result.stderr[-2000:]


@pytest.mark.parametrize(
    ("name", "installed"), [(name, False) for name in sorted(INTERRUPTED)] + [("train", True)]
)
def test_ctrl_c_at_start_up_is_one_line_and_status_130(name, installed, tmp_path):
    """scripts/<name>.py, and the installed command visuomotor-train (its console script)."""
    rng = np.random.default_rng(sum(name.encode()) + installed)  # the moments
    program = f"visuomotor-{name}" if installed else f"{name}.py"
    start = [str(Path(sys.executable).parent / program)] if installed else [
        sys.executable, str(SCRIPTS / program)]  # fmt: skip
    statuses = []
    for k in range(SIGNALS_PER_PROGRAM):
        out = tmp_path / f"out{k}" / ("v.mp4" if name == "video" else "run")
        command = [*start, *INTERRUPTED[name], "--out", str(out)]
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                   text=True)  # fmt: skip
        assert _importing(process), process.communicate()
        moment = rng.uniform(0, START_UP)
        try:
            process.wait(timeout=moment)
        except subprocess.TimeoutExpired:
            process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=300)
        assert process.returncode == 130, (moment, stderr[-2000:])
        assert "Traceback" not in stderr, stderr[-2000:]
        said = [s for s in stderr.replace("\r", "\n").split("\n")
                if s.strip() and not any(mark in s for mark in BAR)]  # fmt: skip
        assert len(said) <= 1 and all(s.startswith(f"{program}: interrupted") for s in said), (
            moment, stderr[-2000:])  # fmt: skip
        statuses.append(process.returncode)
        # Nothing half-written under a final name: no video, no partial; a stopped run keeps
        # a whole checkpoint or no folder.
        assert not out.with_name(out.name + ".partial").exists()
        if name in ("video", "evaluate"):  # not even the folder that would have held it
            assert not out.parent.exists() and "held-out targets" not in stdout
        if name == "train" and out.exists():
            names = {p.name for p in out.iterdir()}  # no lock, no temporary
            assert {"checkpoint.npz"} <= names <= {"checkpoint.npz", "metrics.jsonl"}, names
    assert statuses == [130] * SIGNALS_PER_PROGRAM
