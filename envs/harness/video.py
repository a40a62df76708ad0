"""Writing labelled RGB frames to an H.264 mp4 that browsers, GitHub and editors play.

The encoder is the ffmpeg binary that ``imageio-ffmpeg`` ships inside its wheel (no system
ffmpeg needed): H.264 (``libx264``) in ``yuv420p``, the profile every player decodes, with the
``faststart`` flag so a browser can start playing before the whole file has arrived.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

FONT = cv2.FONT_HERSHEY_SIMPLEX
CODEC, PIXEL_FORMAT = "libx264", "yuv420p"  # H.264 in the colour format every player decodes


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


class VideoWriter:
    """H.264 (``yuv420p``) mp4 writer for RGB frames of one size; use as a context manager.

    ``yuv420p`` needs even image sides: an odd height or width is padded with one black row or
    column. The file is complete once :meth:`close` has run.
    """

    def __init__(self, path: str | Path, fps: float = 10.0) -> None:
        self.path, self.fps = Path(path), fps
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = None  # the imageio-ffmpeg generator, once the frame size is known
        self._shape: tuple[int, int] | None = None  # (height, width) of the input frames
        self.frames = 0

    def write(self, frame: np.ndarray) -> None:
        """Append one (H, W, 3) uint8 RGB frame."""
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
            raise ValueError(f"frames are (H, W, 3) uint8 RGB, got {frame.shape} {frame.dtype}")
        if self._writer is None:
            self._open(frame.shape[:2])
        elif frame.shape[:2] != self._shape:
            raise ValueError(f"frame size {frame.shape[:2]} differs from the first {self._shape}")
        height, width = self._shape
        pad = ((0, height % 2), (0, width % 2), (0, 0))
        self._writer.send(np.ascontiguousarray(np.pad(frame, pad)))
        self.frames += 1

    def _open(self, shape: tuple[int, int]) -> None:
        import imageio_ffmpeg  # imported here: only writing videos needs the ffmpeg binary

        self._shape = (int(shape[0]), int(shape[1]))
        height, width = (n + n % 2 for n in self._shape)
        self._writer = imageio_ffmpeg.write_frames(
            str(self.path),
            (width, height),
            fps=self.fps,
            codec=CODEC,
            pix_fmt_out=PIXEL_FORMAT,
            macro_block_size=1,  # sizes are made even above; no rescaling
            output_params=["-movflags", "+faststart"],
        )
        self._writer.send(None)  # start ffmpeg

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
