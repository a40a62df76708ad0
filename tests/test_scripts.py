"""The command-line scripts end to end on tiny runs: video, train (with resume), evaluate."""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.cli import evaluate, train, video
from envs.harness.film import FILM_PANEL, HOLD_SECONDS

from helpers import SCRIPTS, assert_drawn_png


def _frames(path: Path) -> list[np.ndarray]:
    capture = cv2.VideoCapture(str(path))
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            return frames
        frames.append(frame)


def test_video_writes_moving_frames_that_are_not_blank(tmp_path):
    out = tmp_path / "v.mp4"
    trials, fine = 2, 1
    video.main(["--env", "RiacsReach-v0", "--controller", "analytic", "--trials", str(trials),
                "--fine-moves", str(fine), "--fps", "10", "--out", str(out)])  # fmt: skip
    frames = _frames(out)
    # per trial: the target held, then each move filmed while it settles and held
    hold = round(HOLD_SECONDS * 10)
    assert len(frames) > trials * (fine + 2) * hold
    for frame in frames:
        assert frame.std() > 20 and len(np.unique(frame.reshape(-1, 3), axis=0)) > 50
    assert frames[0].shape[1] == 3 * FILM_PANEL[0]  # left | right | overview
    # The arm moves: the overview changes from frame to frame many more times than a slideshow
    # of one picture per stage would change it.
    overview = [f[:, 2 * FILM_PANEL[0] :].astype(int) for f in frames]
    changes = sum(np.abs(a - b).mean() > 0.1 for a, b in itertools.pairwise(overview))
    assert changes > trials * (fine + 2)  # a slideshow changes once per stage at most


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    train.main(["--trials", "40", "--lattice", "4x3x2", "--eval-every", "20", "--eval-trials",
                "5", "--out", str(out)])  # fmt: skip
    return out


def test_train_writes_map_state_and_metrics(run):
    assert (run / "checkpoint.npz").is_file() and not (run / "run.lock").exists()
    rows = [json.loads(r) for r in (run / "metrics.jsonl").read_text().splitlines()]
    assert [r["trial"] for r in rows] == [0, 20, 40]


def test_evaluate_compares_controllers_on_the_same_targets(run, tmp_path, capsys):
    summary = evaluate.main(["--run", str(run), "--targets", "20", "--compare", "analytic",
                             "random", "--out", str(tmp_path)])  # fmt: skip
    table = capsys.readouterr().out
    names = [row["controller"] for row in summary["controllers"]]
    assert names == ["som mrs+fit+refine", "analytic", "random"]
    for name in names:
        assert name in table
    analytic = summary["controllers"][1]
    assert analytic["mean_mm"][0] < 1e-6  # exact IK with exact projection: no error at all
    random = summary["controllers"][2]
    assert random["mean_mm"][0] > summary["controllers"][0]["mean_mm"][0]
    for plot in ("error_histogram", "lattice_left_camera", "error_vectors", "error_map_coarse",
                 "error_map_final"):  # fmt: skip
        assert_drawn_png(tmp_path / f"{plot}.png")
    # The training's own held-out evaluations: in the run folder, not among this evaluation's.
    assert_drawn_png(run / "learning_curve.png")
    assert not (tmp_path / "learning_curve.png").exists()


def test_train_rejects_a_bad_lattice_with_a_clear_message():
    result = subprocess.run(
        [sys.executable, str(SCRIPTS / "train.py"), "--lattice", "12,x,4"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 2 and "a lattice is written like 12x7x4" in result.stderr
