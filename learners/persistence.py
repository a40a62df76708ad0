"""Saving learned state: one ``.npz`` with named arrays, a JSON configuration and a format
version, written atomically (temporary file in the same folder, then rename)."""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

_KIND, _VERSION, _CONFIG = "__kind__", "__format_version__", "__config__"
#: Mode of written files before the umask, as open() gives (0644 with the usual umask 022).
FILE_MODE = 0o666


class CheckpointError(ValueError):
    """A file that is missing, damaged, or holds something other than what was asked for."""


def _umask() -> int:
    mask = os.umask(0)  # the only way to read it is to set it
    os.umask(mask)
    return mask


def write_atomic(path: str | os.PathLike, write: Callable[[BinaryIO], None]) -> Path:
    """Write a file through ``write(f)`` into a temporary file beside ``path``, flush it to disk,
    then rename it over ``path``: readers see the old file or the new one, never a part. The file
    gets mode 0666 less the umask, as ``open`` would give it."""
    path = Path(path)
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
    payload = {
        _KIND: np.array(kind),
        _VERSION: np.array(version),
        _CONFIG: np.array(json.dumps(config, sort_keys=True)),
        **arrays,
    }
    return write_atomic(path, lambda f: np.savez(f, **payload))


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
        loaded = np.load(path, allow_pickle=False)
        if not isinstance(loaded, np.lib.npyio.NpzFile):  # a .npy (one array) under this name
            raise CheckpointError(
                f"{path}: a single numpy array, not a checkpoint archive; pass the .npz that "
                "save() wrote"
            )
        with loaded as z:
            contents = {k: z[k] for k in z.files}
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
        if isinstance(exc, CheckpointError):
            raise
        raise CheckpointError(
            f"{path}: damaged or truncated ({exc}); restore it from a copy or retrain"
        ) from exc
    if _KIND not in contents or _VERSION not in contents or _CONFIG not in contents:
        raise CheckpointError(f"{path}: not a visuomotor checkpoint (no kind/version/config)")
    found = str(contents.pop(_KIND))
    if found != kind:
        raise CheckpointError(f"{path}: holds a {found!r}, not a {kind!r}")
    try:
        found_version = int(contents.pop(_VERSION))
        config = json.loads(str(contents.pop(_CONFIG)))
    except (TypeError, ValueError) as exc:
        raise CheckpointError(f"{path}: damaged version or configuration ({exc})") from exc
    if found_version != version:
        raise CheckpointError(
            f"{path}: format version {found_version}, this code reads version {version}"
        )
    if not isinstance(config, dict):
        raise CheckpointError(f"{path}: the configuration is {type(config).__name__}, not a dict")
    return config, contents
