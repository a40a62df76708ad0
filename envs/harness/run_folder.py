"""A training run's folder, guarded: one writer at a time (a lock naming its PID), no fresh run
over an old one unless asked, no temporaries left by killed saves, and a metrics log cut back to
the rows its checkpoint knows."""

from __future__ import annotations

import fcntl
import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from learners.persistence import CheckpointError, write_atomic

LOCK_FILE = "run.lock"
METRICS_FILE = "metrics.jsonl"


class RunFolderError(RuntimeError):
    """The run folder is in use by another process, or holds a run that must not be mixed up."""


class RunFolder:
    """``out`` locked for this process (``fcntl.flock``: released by the kernel when the holder
    dies, so a dead writer's lock is simply taken over).

    Raises:
        RunFolderError: another live process holds the folder (the message names its PID).
    """

    def __init__(self, out: str | os.PathLike) -> None:
        self.path = Path(out)
        self.path.mkdir(parents=True, exist_ok=True)
        self._fd: int | None = take_lock(self.path / LOCK_FILE, wait=False)
        for tmp in self.path.glob(".*.tmp"):  # left by saves that were killed
            tmp.unlink(missing_ok=True)

    def claim_fresh(self, owned: tuple[str, ...], force: bool) -> None:
        """Start a new run here: refuse if ``owned`` files of an earlier run exist, unless
        ``force``, which deletes them."""
        old = [name for name in owned if (self.path / name).exists()]
        if old and not force:
            raise RunFolderError(
                f"{self.path} already holds a run ({', '.join(old)}); continue it with --resume, "
                "choose another --out, or start over with --force"
            )
        for name in old:
            (self.path / name).unlink()

    def release(self) -> None:
        if self._fd is not None:
            release_lock(self.path / LOCK_FILE, self._fd)
            self._fd = None


def take_lock(lock: Path, wait: bool) -> int:
    """Lock the file ``lock`` (created if missing) for this process and write its PID into it;
    returns the descriptor that holds the lock (``fcntl.flock``: released by the kernel when
    the process dies).

    Args:
        wait: block while another process holds it; else raise.
    Raises:
        RunFolderError: another live process holds it and not ``wait`` (names its PID).
    """
    while True:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            holder = os.read(fd, 32).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise RunFolderError(
                f"{lock.parent} is in use by process {holder} (lock {lock}); wait for it to "
                "finish or stop it, or write to another --out"
            ) from None
        # The holder we waited on may have removed the lock file meanwhile: lock the file
        # that is there now, not an orphan.
        if lock.exists() and os.stat(lock).st_ino == os.fstat(fd).st_ino:
            break
        os.close(fd)
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()}\n".encode())
    return fd


def release_lock(lock: Path, fd: int) -> None:
    """Remove ``lock`` and release it (``fd`` from :func:`take_lock`)."""
    lock.unlink(missing_ok=True)
    os.close(fd)


@contextmanager
def locked(lock: Path) -> Iterator[None]:
    """Hold ``lock`` for the ``with`` block, waiting while another process holds it."""
    fd = take_lock(lock, wait=True)
    try:
        yield
    finally:
        release_lock(lock, fd)


def truncate_metrics(path: Path, rows: int) -> None:
    """Keep the first ``rows`` rows of a metrics log: later ones (logged after the checkpoint)
    and a torn last line (a killed or full-disk write) go.

    Raises:
        CheckpointError: fewer than ``rows`` readable rows.
    """
    lines = path.read_bytes().split(b"\n") if path.is_file() else []
    kept = []
    for line in lines[:rows]:
        try:
            json.loads(line)
        except ValueError:
            break
        kept.append(line)
    if len(kept) < rows:
        raise CheckpointError(
            f"{path}: {len(kept)} readable rows, the checkpoint counts {rows}; the log was "
            "damaged or replaced; restore it, or start over with --force"
        )
    text = b"".join(line + b"\n" for line in kept)
    if not path.is_file() or path.read_bytes() != text:
        write_atomic(path, lambda f: f.write(text))
