"""Writing labelled RGB frames to an H.264 mp4 that browsers, GitHub and editors play.

The encoder is the ffmpeg binary that ``imageio-ffmpeg`` ships inside its wheel (no system
ffmpeg needed): H.264 (``libx264``) in ``yuv420p``, the profile every player decodes, with the
``faststart`` flag so a browser can start playing before the whole file has arrived. A video
gets its name only once ffmpeg has succeeded and the file holds every frame written.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import tempfile
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import IO, NoReturn

import cv2
import numpy as np

from learners.persistence import OutputError, writing

FONT = cv2.FONT_HERSHEY_SIMPLEX
CODEC, PIXEL_FORMAT = "libx264", "yuv420p"  # H.264 in the colour format every player decodes
CRF = 25  # x264's constant rate factor (0 lossless .. 51 worst): imageio's default quality 5
#: Suffix of the file ffmpeg writes until the video is complete and checked.
PARTIAL = ".partial"
LAST_LINE = 120  # characters of ffmpeg's last message that an error quotes
_ADVICE = "free some space or choose another --out"


def annotate(frame: np.ndarray, lines: Sequence[str], scale: float = 0.5) -> np.ndarray:
    """The RGB frame under a dark band holding the text lines (white); ``scale`` is OpenCV's
    font scale (0.5: 22-pixel lines), the strokes thicken with it."""
    line_height = round(22 * scale / 0.5)
    thickness = max(1, round(scale * 1.6))
    band = np.full((line_height * len(lines) + 8, frame.shape[1], 3), 30, dtype=frame.dtype)
    for i, text in enumerate(lines):
        y = line_height * (i + 1) - 2
        cv2.putText(band, text, (6, y), FONT, scale, (255, 255, 255), thickness, cv2.LINE_AA)
    return np.concatenate([band, frame], axis=0)


class VideoError(OutputError):
    """The encoder failed (no space, an unwritable path, a crash) or its file does not hold the
    frames written; nothing is left under the video's name."""


class VideoWriter:
    """H.264 (``yuv420p``) mp4 writer for RGB frames of one size; use as a context manager.

    ``yuv420p`` needs even image sides: an odd height or width is padded with one black row or
    column. ffmpeg writes ``<name>.partial`` beside the video; :meth:`close` checks its exit
    status and that the file holds every frame, then renames it to the video's name. Any failure
    (or an exception leaving the ``with`` block) removes the partial file: a file under the
    video's name is always complete.

    Raises:
        VideoError: from :meth:`write` or :meth:`close`, when ffmpeg failed (its last message
            in one line).
    """

    def __init__(self, path: str | Path, fps: float = 10.0) -> None:
        self.path, self.fps = Path(path), fps
        self.partial = self.path.with_name(self.path.name + PARTIAL)
        with writing(self.path.parent):
            self.path.parent.mkdir(parents=True, exist_ok=True)
        self._ffmpeg: subprocess.Popen | None = None  # started once the frame size is known
        self._log: IO[bytes] | None = None  # ffmpeg's messages (a file: a pipe could fill up)
        self._shape: tuple[int, int] | None = None  # (height, width) of the input frames
        self.frames = 0

    def write(self, frame: np.ndarray) -> None:
        """Append one (H, W, 3) uint8 RGB frame."""
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
            raise ValueError(f"frames are (H, W, 3) uint8 RGB, got {frame.shape} {frame.dtype}")
        if self._ffmpeg is None:
            self._open(frame.shape[:2])
        elif frame.shape[:2] != self._shape:
            raise ValueError(f"frame size {frame.shape[:2]} differs from the first {self._shape}")
        assert self._ffmpeg is not None and self._ffmpeg.stdin is not None and self._shape
        height, width = self._shape
        pad = ((0, height % 2), (0, width % 2), (0, 0))
        try:
            self._ffmpeg.stdin.write(np.ascontiguousarray(np.pad(frame, pad)).tobytes())
        except OSError:  # ffmpeg quit (BrokenPipeError): its own message says why
            self._fail("ffmpeg stopped while frames were written")
        self.frames += 1

    def _open(self, shape: tuple[int, int]) -> None:
        import imageio_ffmpeg  # imported here: only writing videos needs the ffmpeg binary

        self._shape = (int(shape[0]), int(shape[1]))
        height, width = (n + n % 2 for n in self._shape)
        fps = Fraction(self.fps).limit_denominator()  # a rational: 29.97 is not rounded
        command = [
            imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-v", "error",
            "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{width}x{height}", "-r", str(fps),
            "-i", "-", "-an", "-vcodec", CODEC, "-pix_fmt", PIXEL_FORMAT, "-crf", str(CRF),
            "-movflags", "+faststart", "-f", "mp4", str(self.partial),
        ]  # fmt: skip
        self._log = tempfile.TemporaryFile()
        # Its own session: Ctrl-C reaches this process, which then stops ffmpeg itself.
        self._ffmpeg = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self._log,
            start_new_session=True,
        )  # fmt: skip

    def close(self) -> None:
        """Finish the video: wait for ffmpeg, check its status and the file's frame count, and
        give the file the video's name (nothing to do if no frame was written)."""
        if self._ffmpeg is None:
            return
        assert self._ffmpeg.stdin is not None
        try:
            self._ffmpeg.stdin.close()
        except OSError:
            pass  # ffmpeg quit: its status says why
        if self._ffmpeg.wait() != 0:
            self._fail(f"ffmpeg exited with status {self._ffmpeg.returncode}")
        import imageio_ffmpeg

        try:
            found, _ = imageio_ffmpeg.count_frames_and_secs(str(self.partial))
        except (RuntimeError, OSError) as exc:
            self._fail(f"the written file does not decode ({_last_line(str(exc))})")
        if found != self.frames:
            self._fail(f"the written file holds {found} of {self.frames} frames")
        with writing(self.path, prefer_path=True):
            with open(self.partial, "rb") as f:
                os.fsync(f.fileno())  # on disk before it gets the video's name
            os.replace(self.partial, self.path)
        self._done()

    def abort(self) -> None:
        """Stop ffmpeg and remove the partial file (the video is not wanted)."""
        if self._ffmpeg is not None:
            self._ffmpeg.kill()
            self._ffmpeg.wait()
        with contextlib.suppress(OSError):  # gone, or not ffmpeg's (a folder of that name)
            self.partial.unlink()
        self._done()

    def _fail(self, what: str) -> NoReturn:
        """Raise :class:`VideoError` saying ``what`` and ffmpeg's last message; removes the
        partial file."""
        said = ""
        if self._log is not None:
            self._log.seek(0)
            said = _last_line(self._log.read().decode(errors="replace"))
        self.abort()
        reason = f"{what}: {said}" if said else what
        raise VideoError(f"{self.path}: video not written ({reason}); {_ADVICE}")

    def _done(self) -> None:
        self._ffmpeg = None
        if self._log is not None:
            self._log.close()
            self._log = None

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc: object) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


def _last_line(text: str) -> str:
    """The last non-empty line of ``text``, at most ``LAST_LINE`` characters."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1][:LAST_LINE] if lines else ""
