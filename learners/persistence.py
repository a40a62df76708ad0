"""Saving learned state: one ``.npz`` with named arrays, a JSON configuration and a format
version, written atomically (temporary file in the same folder, then rename)."""

from __future__ import annotations

import errno
import json
import math
import os
import tempfile
import zipfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

_KIND, _VERSION, _CONFIG = "__kind__", "__format_version__", "__config__"
#: Configuration entry that lists the archive's arrays (removed from what ``load_npz`` returns).
_ARRAYS = "__arrays__"
#: General-purpose flag bit of an encrypted zip member.
_ENCRYPTED = 0x1
#: Mode of written files before the umask, as open() gives (0644 with the usual umask 022).
FILE_MODE = 0o666
#: Foreign text quoted in an error (an exception's message, a stored name) is cut to this many
#: characters, so that a damaged file's bytes never make the message longer than a line.
QUOTE_LIMIT = 100


class CheckpointError(ValueError):
    """A file that is missing, damaged, or holds something other than what was asked for."""


def quoted(text: object, limit: int = QUOTE_LIMIT) -> str:
    """``text`` on one line (whitespace runs as one space), cut to ``limit`` characters."""
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[: limit - 3] + "..."


def damaged(path: str | os.PathLike, kind: str, exc: BaseException) -> CheckpointError:
    """The one-line error of a ``kind`` file at ``path`` whose contents do not fit together,
    quoting (cut) what was wrong: ``exc``'s message, or the entry a KeyError names."""
    reason = f"no entry {exc.args[0]!r}" if isinstance(exc, KeyError) and exc.args else exc
    return CheckpointError(
        f"{path}: incomplete or inconsistent {kind} checkpoint ({quoted(reason)}); restore it "
        "from a copy or retrain"
    )


class OutputError(RuntimeError):
    """A file could not be written where it was asked to go: the disk or quota is full, or the
    folder is read-only or forbidden. The message names the path, the cause and what to do."""


#: Why a write fails because of where it goes (not because of a bug), and what to do about it.
_NO_SPACE = "free some space or write to another folder"
_READ_ONLY = "make the folder writable or write to another folder"
OUTPUT_ERRNOS: dict[int, str] = {
    errno.ENOSPC: _NO_SPACE,
    errno.EDQUOT: _NO_SPACE,
    errno.EROFS: _READ_ONLY,
    errno.EACCES: _READ_ONLY,
}


def output_error(
    exc: OSError, path: str | os.PathLike, prefer_path: bool = False
) -> OutputError | None:
    """``exc`` as an :class:`OutputError`, or None if its errno is not one of
    ``OUTPUT_ERRNOS``. It names the file ``exc`` names, else (or if ``prefer_path``) ``path``."""
    advice = OUTPUT_ERRNOS.get(exc.errno or 0)
    if advice is None:
        return None
    name = path if prefer_path or exc.filename is None else exc.filename
    return OutputError(f"{name}: cannot write ({exc.strerror}); {advice}")


@contextmanager
def writing(path: str | os.PathLike, prefer_path: bool = False) -> Iterator[None]:
    """Turn a failed write inside the block (no space, read-only, forbidden) into an
    :class:`OutputError`; ``path`` and ``prefer_path`` choose the name as in
    :func:`output_error`."""
    try:
        yield
    except OSError as exc:
        error = output_error(exc, path, prefer_path)
        if error is None:
            raise
        raise error from exc


def _umask() -> int:
    mask = os.umask(0)  # the only way to read it is to set it
    os.umask(mask)
    return mask


def write_atomic(path: str | os.PathLike, write: Callable[[BinaryIO], None]) -> Path:
    """Write a file through ``write(f)`` into a temporary file beside ``path``, flush it to disk,
    then rename it over ``path``: readers see the old file or the new one, never a part. The file
    gets mode 0666 less the umask, as ``open`` would give it.

    Raises:
        OutputError: no space, or a read-only or forbidden folder (the old file is kept).
    """
    path = Path(path)
    with writing(path, prefer_path=True):  # not the temporary file's name
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        try:
            os.fchmod(fd, FILE_MODE & ~_umask())  # mkstemp makes 0600; others may read results
            with os.fdopen(fd, "wb") as f:
                write(f)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    return path


def save_npz(
    path: str | os.PathLike,
    kind: str,
    version: int,
    config: dict[str, Any],
    arrays: dict[str, np.ndarray],
) -> Path:
    """Write ``arrays`` and ``config`` to ``path`` atomically; returns the path."""
    stored = {**config, _ARRAYS: sorted(arrays)}  # so that a lost directory entry is seen
    payload = {
        _KIND: np.array(kind),
        _VERSION: np.array(version),
        _CONFIG: np.array(json.dumps(stored, sort_keys=True)),
        **arrays,
    }
    return write_atomic(path, lambda f: np.savez(f, **payload))  # type: ignore[arg-type]  # numpy's stub types savez's keyword arrays as its allow_pickle flag


def load_npz(
    path: str | os.PathLike, kind: str, version: int
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read a file written by :func:`save_npz` for ``kind``; returns (config, arrays).

    Raises:
        CheckpointError: the file is missing, truncated or not a numpy archive, holds another
            kind of state, or was written by another format version.
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: no such file; check the path or train a model first")
    try:
        contents = _read_archive(path)
    except CheckpointError:
        raise
    except Exception as exc:  # any other failure to parse these bytes is damage, not a bug
        raise CheckpointError(
            f"{path}: damaged or truncated ({quoted(f'{type(exc).__name__}: {exc}')}); restore "
            "it from a copy or retrain"
        ) from exc
    if _KIND not in contents or _VERSION not in contents or _CONFIG not in contents:
        raise CheckpointError(f"{path}: not a visuomotor checkpoint (no kind/version/config)")
    found = str(contents.pop(_KIND))
    if found != kind:
        raise CheckpointError(f"{path}: holds a {quoted(repr(found))}, not a {kind!r}")
    try:
        found_version = int(contents.pop(_VERSION))
        config = json.loads(str(contents.pop(_CONFIG)))
    except (TypeError, ValueError, OverflowError, RecursionError) as exc:
        raise CheckpointError(f"{path}: damaged version or configuration ({quoted(exc)})") from exc
    if found_version != version:
        raise CheckpointError(
            f"{path}: format version {found_version}, this code reads version {version}"
        )
    if not isinstance(config, dict):
        raise CheckpointError(f"{path}: the configuration is {type(config).__name__}, not a dict")
    names = config.pop(_ARRAYS, None)  # None: a file from before the list was written
    if names is not None and names != sorted(contents):
        listed = (
            set(names)
            if isinstance(names, list) and all(isinstance(n, str) for n in names)
            else set()
        )
        extra, lacking = sorted(set(contents) - listed), sorted(listed - set(contents))
        raise CheckpointError(
            f"{path}: its arrays differ from the list in its configuration (not listed: "
            f"{quoted(extra, 40)}; missing: {quoted(lacking, 40)}); the file is damaged"
        )
    return config, contents


def stored_kind(path: str | os.PathLike) -> str | None:
    """The kind of state a file written by :func:`save_npz` holds, or None if ``path`` is not
    such a file (:func:`load_npz` then says what is wrong with it)."""
    try:
        with np.load(path, allow_pickle=False) as archive:
            return str(archive[_KIND])
    except Exception:
        return None


def _read_archive(path: Path) -> dict[str, np.ndarray]:
    """The arrays of an archive that :func:`save_npz` wrote, read strictly: every member stored
    uncompressed and unencrypted (as ``np.savez`` writes them), a ``.npy`` header whose shape and
    dtype account for exactly the member's bytes (so a damaged header cannot ask for a huge
    allocation), no Python objects, and the member's CRC checked."""
    if not zipfile.is_zipfile(path):
        with open(path, "rb") as f:
            magic = np.lib.format.MAGIC_PREFIX  # the first bytes of a .npy file
            if f.read(len(magic)) == magic:  # a .npy (one array) under this name
                raise CheckpointError(
                    f"{path}: a single numpy array, not a checkpoint archive; pass the .npz that "
                    "save() wrote"
                )
        raise CheckpointError(
            f"{path}: damaged or truncated (no zip directory); restore it from a copy or retrain"
        )
    contents = {}
    with zipfile.ZipFile(path) as archive:
        for info in archive.infolist():
            name = info.filename.removesuffix(".npy")
            if info.compress_type != zipfile.ZIP_STORED or info.flag_bits & _ENCRYPTED:
                raise CheckpointError(
                    f"{path}: member {quoted(repr(info.filename), 40)} is compressed or "
                    "encrypted, which save() never writes; the file is damaged or foreign"
                )
            if name == info.filename or name in contents:
                raise CheckpointError(
                    f"{path}: unexpected member {quoted(repr(info.filename), 40)}"
                )
            with archive.open(info) as member:
                version = np.lib.format.read_magic(member)
                if version == (1, 0):
                    shape, fortran, dtype = np.lib.format.read_array_header_1_0(member)
                else:
                    shape, fortran, dtype = np.lib.format.read_array_header_2_0(member)
                size = math.prod(shape) * dtype.itemsize
                if dtype.hasobject or member.tell() + size != info.file_size:
                    raise CheckpointError(
                        f"{path}: array {quoted(repr(name), 40)} ({quoted(dtype, 30)} "
                        f"{quoted(shape, 40)}) does not match its {info.file_size} stored "
                        "bytes; the file is damaged"
                    )
                data = member.read(size)
                member.read()  # to the end: zipfile checks the CRC there
            contents[name] = (
                np.frombuffer(data, dtype=dtype)
                .reshape(shape, order="F" if fortran else "C")
                .copy()
            )
    return contents
