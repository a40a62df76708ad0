"""envs.harness.video: H.264 mp4 files that decode (OpenCV) with the frames that were written."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from envs.harness.video import VideoError, VideoWriter

COLOURS = [(230, 30, 30), (30, 230, 30), (30, 30, 230), (200, 200, 40)]  # RGB, one per frame
COLOUR_TOL = 12  # per channel: H.264 at default quality and yuv420p chroma are lossy
H264_TAGS = {"avc1", "h264"}


def _fourcc(capture: cv2.VideoCapture) -> str:
    code = int(capture.get(cv2.CAP_PROP_FOURCC))
    return "".join(chr((code >> (8 * i)) & 0xFF) for i in range(4)).lower()


@pytest.mark.parametrize("size", [(48, 64), (47, 63)])  # even, and odd sides (padded)
def test_h264_file_decodes_with_the_written_frames(tmp_path, size):
    path = tmp_path / "sub" / "clip.mp4"
    with VideoWriter(path, fps=5) as video:
        for colour in COLOURS:
            video.write(np.full((*size, 3), colour, dtype=np.uint8))
    capture = cv2.VideoCapture(str(path))
    assert _fourcc(capture) in H264_TAGS
    assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == len(COLOURS)
    decoded = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        decoded.append(frame[..., ::-1])  # BGR -> RGB
    assert len(decoded) == len(COLOURS) == video.frames
    for frame, colour in zip(decoded, COLOURS, strict=True):
        assert frame.shape[:2] == (size[0] + size[0] % 2, size[1] + size[1] % 2)
        centre = frame[: size[0], : size[1]][2:-2, 2:-2].reshape(-1, 3).mean(axis=0)
        np.testing.assert_allclose(centre, colour, atol=COLOUR_TOL)


def test_bad_frames_are_refused(tmp_path):
    with VideoWriter(tmp_path / "a.mp4") as video:
        with pytest.raises(ValueError, match="uint8 RGB"):
            video.write(np.zeros((8, 8), dtype=np.uint8))
        video.write(np.zeros((8, 8, 3), dtype=np.uint8))
        with pytest.raises(ValueError, match="differs from the first"):
            video.write(np.zeros((16, 8, 3), dtype=np.uint8))


def test_a_failed_encoder_is_one_line_and_leaves_the_old_video(tmp_path):
    """ffmpeg cannot open its output (a folder holds the partial file's name): VideoError in
    one line quoting ffmpeg, nothing under the video's name but the old file, unchanged."""
    path = tmp_path / "clip.mp4"
    path.write_bytes(b"an older video")
    (tmp_path / "clip.mp4.partial").mkdir()
    with pytest.raises(VideoError) as caught:
        with VideoWriter(path, fps=5) as video:
            for colour in COLOURS * 50:  # enough bytes to fill the pipe to a dead ffmpeg
                video.write(np.full((48, 64, 3), colour, dtype=np.uint8))
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"{path}: video not written (ffmpeg")
    assert path.read_bytes() == b"an older video"


def test_an_exception_while_filming_keeps_no_file(tmp_path):
    path = tmp_path / "clip.mp4"
    with pytest.raises(KeyboardInterrupt):
        with VideoWriter(path, fps=5) as video:
            video.write(np.zeros((48, 64, 3), dtype=np.uint8))
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []
