"""Kill test: real ``scripts/train.py`` processes get SIGINT, SIGTERM and SIGKILL at random
moments, are resumed each time, and must end with the checkpoint (map arrays, generator states,
simulation state) and metrics.jsonl of an unbroken run, exactly.

``make soak`` runs the long version (``VISUOMOTOR_SOAK=1``: more trials and signals).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

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
]  # fmt: skip
COMMON = ["--lattice", "4,3,2", "--checkpoint-every", "7", "--seed", "5"]
if SOAK:  # ten times the trials and the signals

    def _longer(options: list[str]) -> list[str]:
        i = options.index("--trials") + 1
        return [*options[:i], str(10 * int(options[i])), *options[i + 1 :]]

    SETTINGS = [(name, _longer(opts), 10 * n) for name, opts, n in SETTINGS]


def _command(out: Path, options: list[str]) -> list[str]:
    resume = (out / "som.npz").is_file()  # a run killed before its first save starts afresh
    return [sys.executable, str(SCRIPT), *options, *COMMON, "--out", str(out)] + (
        ["--resume"] if resume else []
    )


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONUNBUFFERED": "1"}


def _contents(out: Path) -> dict[str, np.ndarray]:
    with np.load(out / "som.npz") as z:
        return {k: z[k] for k in z.files}


def _timed(command: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True, env=_env())
    return time.perf_counter() - start


def _signalled_run(
    out: Path, options: list[str], n_signals: int, longest: float, rng: np.random.Generator
) -> list[int]:
    """Run to the end, sending at most ``n_signals`` signals, each at a moment drawn uniformly
    from (0, ``longest``) s after a process starts; returns the exit statuses of the processes
    that were stopped."""
    statuses: list[int] = []
    while True:
        process = subprocess.Popen(
            _command(out, options), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=_env()
        )
        if len(statuses) < n_signals:
            try:
                process.wait(timeout=float(rng.uniform(0.0, longest)))
            except subprocess.TimeoutExpired:
                process.send_signal(SIGNALS[int(rng.integers(len(SIGNALS)))])
        _, err = process.communicate(timeout=300)
        if process.returncode == 0:
            return statuses
        # SIGINT while the interpreter itself starts: a KeyboardInterrupt, status 1.
        early = process.returncode == 1 and b"KeyboardInterrupt" in err
        assert process.returncode in STOPPED or early, err.decode()[-2000:]
        statuses.append(process.returncode)


@pytest.mark.parametrize("name,options,n_signals", SETTINGS, ids=[s[0] for s in SETTINGS])
def test_signals_at_random_moments_leave_the_result_of_an_unbroken_run(
    tmp_path, name, options, n_signals
):
    reference = tmp_path / "reference"
    startup = _timed([sys.executable, str(SCRIPT), "--help"])  # s, imports
    work = _timed(_command(reference, options)) - startup  # s, the whole run's work
    # Moments spread over start-up and a share of the work, so that the signals fall into
    # imports, trials, evaluations and saves alike. A run that ends before all signals were
    # sent (timing varies with the machine's load) is followed by another one.
    longest = startup + max(work, 0.1) / n_signals
    expected = _contents(reference)
    metrics = (reference / "metrics.jsonl").read_bytes()
    rng = np.random.default_rng(sum(name.encode()))  # the moments and the signals
    statuses: list[int] = []
    runs = 0
    while len(statuses) < n_signals:
        out = tmp_path / f"killed{runs}"
        statuses += _signalled_run(out, options, n_signals - len(statuses), longest, rng)
        runs += 1
        found = _contents(out)
        assert sorted(found) == sorted(expected)
        for key in expected:
            np.testing.assert_array_equal(found[key], expected[key], err_msg=key)
        assert (out / "metrics.jsonl").read_bytes() == metrics
    counts = {code: statuses.count(code) for code in sorted(set(statuses))}
    print(f"\n{name}: {len(statuses)} signals, {runs} runs, exit statuses {counts}")
