"""Kill test: real ``scripts/train.py`` processes (on the reach envs and on the grasp env
``PumaGrasp-v0``) get SIGINT, SIGTERM and SIGKILL at random moments, are resumed each time, and
must end with the checkpoint (map arrays, generator states, simulation state) and metrics.jsonl
of an unbroken run, exactly.

``make soak`` runs the long version (``VISUOMOTOR_SOAK=1``: more trials and signals).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "train.py"
SOAK = os.environ.get("VISUOMOTOR_SOAK") == "1"
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGKILL)
#: Exit statuses a stopped run may give: done, stopped by SIGINT/SIGTERM after saving (130,
#: 143), killed (-9), or hit by SIGINT/SIGTERM before its handlers were installed (-2, -15).
STOPPED = {130, 143, -signal.SIGKILL, -signal.SIGINT, -signal.SIGTERM}
#: (name, train.py options, signals to send). Each run is a few seconds of work: few trials, a
#: small held-out set, frequent checkpoints.
SETTINGS = [
    ("project-kinematic", ["--sensing", "project", "--control", "kinematic", "--trials", "800",
                           "--eval-every", "200", "--eval-trials", "30"], 12),
    ("render-servo", ["--sensing", "render", "--control", "servo", "--trials", "24",
                      "--eval-every", "8", "--eval-trials", "3"], 10),
    ("keep-arm-servo", ["--sensing", "project", "--control", "servo", "--keep-arm", "--trials",
                        "300", "--eval-every", "60", "--eval-trials", "5"], 10),
    ("pose-project", ["--env", "PumaGrasp-v0", "--orientation-lattice", "2", "--sensing",
                      "project", "--control", "kinematic", "--trials", "600", "--eval-every",
                      "150", "--eval-trials", "20"], 10),
]  # fmt: skip
#: Share of the signals sent during a process's start-up rather than its work.
STARTUP_SHARE = 0.25
COMMON = ["--lattice", "4x3x2", "--checkpoint-every", "7", "--seed", "5"]
if SOAK:  # ten times the trials and the signals

    def _longer(options: list[str]) -> list[str]:
        i = options.index("--trials") + 1
        return [*options[:i], str(10 * int(options[i])), *options[i + 1 :]]

    SETTINGS = [(name, _longer(opts), 10 * n) for name, opts, n in SETTINGS]
#: A soak of one setting with more signals: VISUOMOTOR_SOAK_ONLY=keep-arm-servo
#: VISUOMOTOR_SOAK_SIGNALS=1000 (consecutive runs of the setting until that many were sent).
if os.environ.get("VISUOMOTOR_SOAK_ONLY"):
    SETTINGS = [s for s in SETTINGS if s[0] == os.environ["VISUOMOTOR_SOAK_ONLY"]]
    assert SETTINGS, f"VISUOMOTOR_SOAK_ONLY names no setting of {[s[0] for s in SETTINGS]}"
if os.environ.get("VISUOMOTOR_SOAK_SIGNALS"):
    SETTINGS = [(n, o, int(os.environ["VISUOMOTOR_SOAK_SIGNALS"])) for n, o, _ in SETTINGS]


def _command(out: Path, options: list[str]) -> list[str]:
    resume = (out / "checkpoint.npz").is_file()  # a run killed before its first save starts afresh
    return [sys.executable, str(SCRIPT), *options, *COMMON, "--out", str(out)] + (
        ["--resume"] if resume else []
    )


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONUNBUFFERED": "1"}


def _contents(out: Path) -> dict[str, np.ndarray]:
    with np.load(out / "checkpoint.npz") as z:
        return {k: z[k] for k in z.files}


def _timed(command: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True, env=_env())
    return time.perf_counter() - start


def _working(process: subprocess.Popen, out: Path) -> bool:
    """Wait until ``process`` holds the run folder's lock (its start-up is over); False if it
    ended first."""
    lock = out / "run.lock"
    while process.poll() is None:
        with contextlib.suppress(OSError):
            if lock.read_text().strip() == str(process.pid):
                return True
        time.sleep(0.005)
    return False


def _signalled_run(
    out: Path,
    options: list[str],
    n_signals: int,
    startup: float,
    share: float,
    rng: np.random.Generator,
) -> list[int]:
    """Run to the end, sending at most ``n_signals`` signals, and return the exit statuses of
    the stopped processes. A signal falls, with probability STARTUP_SHARE, at a moment drawn
    uniformly from (0, ``startup``) s after the process started (imports, building the env,
    reading the checkpoint), else from (0, 2·``share``) s after it took the run folder's lock
    (trials, evaluations, saves).

    For a difference to be traced, every process's starting checkpoint is kept in
    ``OUT-starts/`` and a line per process (start trial, signal, moment, exit status) is
    appended to ``OUT.log``.
    """
    statuses: list[int] = []
    starts = out.parent / f"{out.name}-starts"
    starts.mkdir(parents=True, exist_ok=True)
    while True:
        k, start = len(statuses), "fresh"
        if (out / "checkpoint.npz").is_file():
            shutil.copy(out / "checkpoint.npz", starts / f"{k:03d}.npz")
            with np.load(starts / f"{k:03d}.npz") as z:
                run = json.loads(str(z["run"]))
            start = f"trial {run['trial']}" + (
                " (evaluation pending)" if run["pending_eval"] else ""
            )
        process = subprocess.Popen(
            _command(out, options), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=_env()
        )
        sent, interrupted_start = "no signal", False
        if len(statuses) < n_signals:
            early, fraction = rng.random() < STARTUP_SHARE, rng.random()
            ready = early or _working(process, out)
            delay = fraction * (startup if early else 2 * share)
            try:
                process.wait(timeout=delay)
            except subprocess.TimeoutExpired:
                if ready:
                    sig = SIGNALS[int(rng.integers(len(SIGNALS)))]
                    process.send_signal(sig)
                    interrupted_start = early and sig == signal.SIGINT
                    phase = "start" if early else "lock"
                    sent = f"{sig.name} {delay:.3f} s after its {phase}"
        _, err = process.communicate(timeout=300)
        with open(out.parent / f"{out.name}.log", "a") as log:
            log.write(f"process {k}: from {start}, {sent}, exit {process.returncode}\n")
        if process.returncode == 0:
            return statuses
        # SIGINT while the interpreter itself starts, before the handlers are installed: status
        # 1, a KeyboardInterrupt (or, inside a C extension's import, the ImportError it causes).
        early_exit = process.returncode == 1 and interrupted_start
        assert process.returncode in STOPPED or early_exit, err.decode()[-2000:]
        statuses.append(process.returncode)


def _check_setting(tmp_path: Path, name: str, options: list[str], n_signals: int) -> str:
    """Signal runs of one setting until ``n_signals`` were sent, comparing every run with an
    unbroken one; returns a summary line."""
    reference = tmp_path / name / "reference"
    startup = _timed([sys.executable, str(SCRIPT), "--help"])  # s, imports
    work = _timed(_command(reference, options)) - startup  # s, the whole run's work
    # Each process gets about its share of the work before its signal, so the run ends after
    # about n_signals signals; a run that ends before they were all sent (timing varies with
    # the machine's load) is followed by another one.
    share = max(work, 0.1) / n_signals
    expected = _contents(reference)
    metrics = (reference / "metrics.jsonl").read_bytes()
    rng = np.random.default_rng(sum(name.encode()))  # the moments and the signals
    statuses: list[int] = []
    runs = 0
    while len(statuses) < n_signals:
        out = tmp_path / name / f"killed{runs}"
        left = n_signals - len(statuses)
        statuses += _signalled_run(out, options, left, startup, share, rng)
        runs += 1
        found = _contents(out)
        assert sorted(found) == sorted(expected), name
        trace = f"processes in {out}.log, their starting checkpoints in {out}-starts"
        for key in expected:
            np.testing.assert_array_equal(
                found[key], expected[key], err_msg=f"{name}: {key}; {trace}"
            )
        assert (out / "metrics.jsonl").read_bytes() == metrics, name
    counts = {code: statuses.count(code) for code in sorted(set(statuses))}
    return f"{name}: {len(statuses)} signals, {runs} runs, exit statuses {counts}"


def test_signals_at_random_moments_leave_the_result_of_an_unbroken_run(tmp_path):
    """The settings run side by side: most of the time goes into waiting for the moments."""
    start = time.perf_counter()
    with ThreadPoolExecutor(len(SETTINGS)) as pool:
        jobs = [pool.submit(_check_setting, tmp_path, *setting) for setting in SETTINGS]
        lines = [job.result() for job in jobs]
    print("\n" + "\n".join(lines) + f"\nin {time.perf_counter() - start:.0f} s")
