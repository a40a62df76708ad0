"""SignalStop notes SIGINT and SIGTERM and raises only at the loop's own checks."""

from __future__ import annotations

import os
import signal

import pytest

from envs.harness.stopping import SignalStop, StopRequested


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_is_noted_and_raised_only_at_a_check(sig):
    """The handler itself never raises: a raise inside a C library's callback into Python
    (llvmlite's, while numba compiles) is swallowed there and left the process to segfault."""
    before = signal.getsignal(sig)
    with SignalStop() as stop:
        stop.check()  # nothing noted yet
        os.kill(os.getpid(), sig)  # delivered to this (main) thread before kill returns
        assert stop.signum == sig
        with pytest.raises(StopRequested) as stopped:
            stop.check()
    assert stopped.value.exit_code == 128 + sig
    assert signal.getsignal(sig) is before  # the previous handler is back
