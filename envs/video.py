"""Writing labelled RGB frames to an mp4 with OpenCV (headless)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

FONT = cv2.FONT_HERSHEY_SIMPLEX


def annotate(frame: np.ndarray, lines: Sequence[str], scale: float = 0.5) -> np.ndarray:
    """The RGB frame under a dark band holding the text lines (white)."""
    line_height = round(22 * scale / 0.5)
    band = np.full((line_height * len(lines) + 8, frame.shape[1], 3), 30, dtype=frame.dtype)
    for i, text in enumerate(lines):
        y = line_height * (i + 1) - 2
        cv2.putText(band, text, (6, y), FONT, scale, (255, 255, 255), 1, cv2.LINE_AA)
    return np.concatenate([band, frame], axis=0)


class VideoWriter:
    """mp4 (``mp4v``) writer for RGB frames of one size; use as a context manager."""

    def __init__(self, path: str | Path, fps: float = 10.0) -> None:
        self.path, self.fps = Path(path), fps
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer: cv2.VideoWriter | None = None
        self.frames = 0

    def write(self, frame: np.ndarray) -> None:
        if self._writer is None:
            height, width = frame.shape[:2]
            fourcc = cv2.VideoWriter_fourcc(*"mp4v")
            self._writer = cv2.VideoWriter(str(self.path), fourcc, self.fps, (width, height))
            if not self._writer.isOpened():
                raise RuntimeError(f"OpenCV cannot write {self.path} (mp4v codec unavailable)")
        self._writer.write(np.ascontiguousarray(frame[..., ::-1]))  # RGB -> BGR
        self.frames += 1

    def close(self) -> None:
        if self._writer is not None:
            self._writer.release()
            self._writer = None

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
