"""Stopping a training run on SIGINT (Ctrl-C) or SIGTERM at a point from which it continues
exactly: the signal is noted, the current trial finishes, and the loop stops at its next check.
Work that can simply be redone (a held-out evaluation) is abandoned at once instead."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
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

    ``check()`` raises :class:`StopRequested` once a signal was noted. Inside ``abandonable()``
    a signal raises it at once (the caller redoes that work later). Outside the main thread
    (where Python cannot catch signals) it installs nothing.
    """

    def __init__(self) -> None:
        self.signum: int | None = None
        self._abandonable = False
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
        if self._abandonable:
            self._abandonable = False
            raise StopRequested(signum)

    def check(self) -> None:
        if self.signum is not None:
            raise StopRequested(self.signum)

    @contextmanager
    def abandonable(self) -> Iterator[None]:
        """``with stop.abandonable(): work()``: a signal stops ``work`` at once."""
        self._abandonable = True
        try:
            self.check()
            yield
        finally:
            self._abandonable = False
