"""Stopping a training run on SIGINT (Ctrl-C) or SIGTERM at a point from which it continues
exactly: the signal is noted, the current trial finishes, and the loop stops at its next check.
Work that can simply be redone (a held-out evaluation) checks before each of its trials and is
abandoned there.

The handler only notes the signal. A handler that raises can run inside a C library's callback
into Python (llvmlite's ctypes callbacks while numba compiles or loads its cache): the exception
is swallowed there and the library is left broken, and the process dies of a segfault."""

from __future__ import annotations

import signal
import threading
from types import FrameType

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopRequested(BaseException):
    """A stop signal arrived; ``exit_code`` is the shell's 128 + signal number (130, 143).

    A BaseException, like KeyboardInterrupt, so that ``except Exception`` does not swallow it.
    """

    def __init__(self, signum: int) -> None:
        self.signum = signum
        self.exit_code = 128 + signum
        super().__init__(f"stopped by {signal.Signals(signum).name}")


class SignalStop:
    """Context manager that turns SIGINT and SIGTERM into a noted request.

    ``check()`` raises :class:`StopRequested` once a signal was noted. Outside the main thread
    (where Python cannot catch signals) it installs nothing.
    """

    def __init__(self) -> None:
        self.signum: int | None = None
        self._previous: dict[int, object] = {}

    def __enter__(self) -> SignalStop:
        if threading.current_thread() is threading.main_thread():
            for sig in SIGNALS:
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        self.signum = signum

    def check(self) -> None:
        if self.signum is not None:
            raise StopRequested(self.signum)
