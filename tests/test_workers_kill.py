"""Kill test of training with workers: a real ``scripts/train.py --workers 2`` gets SIGKILL,
SIGTERM or SIGINT at a random moment after its workers ran their first round (the learner only:
its workers end with it), is resumed each time, and must end with the checkpoint and
metrics.jsonl of an unbroken run, exactly. ``make soak`` sends ten times the signals
(``VISUOMOTOR_SOAK=1``).
"""

from __future__ import annotations

import signal
import subprocess
import time

import numpy as np
from test_kill import SOAK, _command, _contents, _env, _working

SIGNALS = 30 if SOAK else 3
#: Projection and servo moves, a held-out evaluation every 128 trials: rounds of 128 trials, a few
#: tenths of a second each; the soak's run long enough for its signals.
OPTIONS = ["--workers", "2", "--control", "servo", "--trials", "4096" if SOAK else "512",
           "--eval-every", "128", "--eval-trials", "10"]  # fmt: skip
#: SIGKILL twice as often as each stop signal: it leaves the workers without their learner.
KINDS = (signal.SIGKILL, signal.SIGKILL, signal.SIGTERM, signal.SIGINT)
#: s: a signal falls uniformly within this time after the process's first round was saved.
WITHIN = 1.5


def _first_round_saved(process: subprocess.Popen, checkpoint, before: int) -> bool:
    """Wait until ``checkpoint`` was written again (its mtime moved from ``before``): a round
    was learned. False if the process ended first."""
    while process.poll() is None:
        if checkpoint.is_file() and checkpoint.stat().st_mtime_ns != before:
            return True
        time.sleep(0.005)
    return False


def test_workers_resume_bit_identically_after_signals_at_random_moments(tmp_path):
    reference, out = tmp_path / "reference", tmp_path / "signalled"
    subprocess.run(_command(reference, OPTIONS), check=True, capture_output=True, env=_env())
    rng = np.random.default_rng(35)
    sent: list[tuple[str, int]] = []
    while True:
        checkpoint = out / "checkpoint.npz"
        before = checkpoint.stat().st_mtime_ns if checkpoint.is_file() else 0
        process = subprocess.Popen(
            _command(out, OPTIONS), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=_env()
        )
        if len(sent) < SIGNALS and _working(process, out):
            if checkpoint.is_file():  # the fresh run's first save is its trial 0
                before = checkpoint.stat().st_mtime_ns
            if _first_round_saved(process, checkpoint, before):
                time.sleep(float(rng.uniform(0.0, WITHIN)))
                kind = KINDS[int(rng.integers(len(KINDS)))]
                process.send_signal(kind)
                sent.append((kind.name, 0))
        _, err = process.communicate(timeout=300)
        if sent and sent[-1][1] == 0:
            sent[-1] = (sent[-1][0], process.returncode)
        if process.returncode == 0:
            break
        assert process.returncode in (130, 143, -signal.SIGKILL), err.decode()[-2000:]
    assert len(sent) >= 2, f"the run ended after {sent}; give it more trials"
    expected, found = _contents(reference), _contents(out)
    assert sorted(found) == sorted(expected)
    for key in expected:
        np.testing.assert_array_equal(found[key], expected[key], err_msg=f"{key} after {sent}")
    assert (out / "metrics.jsonl").read_bytes() == (reference / "metrics.jsonl").read_bytes()
    print(f"\nsignals and exit statuses: {sent}")
