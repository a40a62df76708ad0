"""A training run's folder, guarded: one writer at a time (a lock naming its PID), no fresh run
over an old one unless asked, no temporaries left by killed saves, a metrics log cut back to
the rows its checkpoint knows, and output folders found unwritable before any work."""

from __future__ import annotations

import fcntl
import itertools
import json
import os
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from learners.persistence import CheckpointError, write_atomic, writing

LOCK_FILE = "run.lock"
METRICS_FILE = "metrics.jsonl"


class RunFolderError(RuntimeError):
    """The run folder is in use by another process, or holds a run that must not be mixed up."""


class RunFolder:
    """``out`` locked for this process (``fcntl.flock``: released by the kernel when the holder
    dies, so a dead writer's lock is simply taken over).

    Raises:
        RunFolderError: another live process holds the folder (the message names its PID).
        OutputError: the folder cannot be created or written (read-only, no space).
    """

    def __init__(self, out: str | os.PathLike) -> None:
        self.path = Path(out)
        with writing(self.path):
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
        OutputError: the lock cannot be created or its PID written (read-only folder, no
            space); no lock file is left behind.
    """
    while True:
        with writing(lock):
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
    try:
        with writing(lock):
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
    except BaseException:
        release_lock(lock, fd)  # an empty lock would name no holder
        raise
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
    kept = lines[: len(_readable_rows(lines[:rows]))]
    if len(kept) < rows:
        raise CheckpointError(
            f"{path}: {len(kept)} readable rows, the checkpoint counts {rows}; the log was "
            "damaged or replaced; restore it, or start over with --force"
        )
    text = b"".join(line + b"\n" for line in kept)
    if not path.is_file() or path.read_bytes() != text:
        write_atomic(path, lambda f: f.write(text))


def check_metrics(path: Path, rows: int, trial: int, pending_eval: bool, eval_every: int) -> None:
    """Check, without writing, that the first ``rows`` rows of a metrics log are the ones a
    checkpoint at ``trial`` (its evaluation there still to do if ``pending_eval``) counts: rows
    of increasing trials up to it, among them every ``eval_every``-th trial from 0 (the run's
    held-out schedule; other rows are the ends of the run's earlier extents), and the next
    row, if any, logged after it.

    Raises:
        CheckpointError: fewer than ``rows`` readable rows, or rows that disagree with the
            count or the schedule (the checkpoint or the log was damaged).
    """
    lines = path.read_bytes().split(b"\n") if path.is_file() else []
    kept = _readable_rows(lines[: rows + 1])
    if len(kept) < rows:
        raise CheckpointError(
            f"{path}: {len(kept)} readable rows, the checkpoint counts {rows}; the log was "
            "damaged or replaced; restore it, or start over with --force"
        )
    trials = [row.get("trial") if isinstance(row, dict) else None for row in kept]
    last = trial - 1 if pending_eval else trial  # the latest trial a counted row may have
    counted = trials[:rows]
    if not all(isinstance(t, int) and 0 <= t <= last for t in counted) or any(
        a >= b for a, b in itertools.pairwise(counted)
    ):
        raise CheckpointError(
            f"{path}: the {rows} rows the checkpoint counts are not of increasing trials up to "
            f"{last}; the checkpoint's metrics_rows or the log is damaged"
        )
    missed = sorted(set(range(0, last + 1, eval_every)) - set(counted))
    if missed:
        raise CheckpointError(
            f"{path}: no row of trial {missed[0]} among the {rows} the checkpoint counts, where "
            f"the run evaluates every {eval_every} trials; its metrics_rows or eval_every, or "
            "the log, is damaged"
        )
    if len(trials) > rows and isinstance(trials[rows], int) and trials[rows] <= last:
        raise CheckpointError(
            f"{path}: row {rows + 1} (trial {trials[rows]}) was logged before the checkpoint "
            f"(trial {trial}), which counts only {rows} rows; its metrics_rows is damaged"
        )


def write_json(path: str | os.PathLike, data: Any) -> Path:
    """``data`` as JSON (indent 1) in ``path``, written atomically (:func:`write_atomic`)."""
    text = json.dumps(data, indent=1).encode()
    return write_atomic(path, lambda f: f.write(text))


def check_writable(folder: str | os.PathLike) -> Path:
    """Write (and remove) a one-byte file in ``folder``, or in its nearest existing ancestor
    if it does not exist yet, so that a read-only folder or a full disk is found before any
    work; nothing is left behind (a refused run creates no folder). Returns ``folder``.

    Raises:
        OutputError: that folder cannot be written.
    """
    folder = Path(folder)
    existing = next(p for p in (folder, *folder.absolute().parents) if p.is_dir())
    with writing(folder, prefer_path=True):  # not the probe's name
        fd, probe = tempfile.mkstemp(prefix=".probe.", suffix=".tmp", dir=existing)
        try:
            os.write(fd, b"\0")
            os.fsync(fd)
        finally:
            os.close(fd)
            os.unlink(probe)
    return folder


def _note(message: str) -> None:
    print(f"note: {message}", file=sys.stderr)


def read_metrics(path: Path, report: Callable[[str], None] = _note) -> list[dict[str, Any]]:
    """The rows of a metrics log. A torn last line (a write cut short by a kill or a full disk,
    which ``--resume`` cuts away) is left out and reported through ``report`` as one line.

    Raises:
        CheckpointError: a row before the last is unreadable (the log was damaged).
    """
    lines = path.read_bytes().split(b"\n")
    if lines[-1] == b"":
        lines.pop()  # the newline that ends the last complete row
    rows = _readable_rows(lines)
    if len(rows) < len(lines) - 1:
        raise CheckpointError(
            f"{path}: row {len(rows) + 1} of {len(lines)} is unreadable; the log was damaged; "
            "restore it, or evaluate with --no-plots"
        )
    if len(rows) < len(lines):
        report(f"{path}: left out its torn last line (a write cut short), as --resume would")
    return rows


def _readable_rows(lines: list[bytes]) -> list[Any]:
    """The rows of ``lines`` (JSON each) up to the first that does not parse."""
    rows = []
    for line in lines:
        try:
            rows.append(json.loads(line))
        except ValueError:
            break
    return rows
