"""Re-adaptation after a change (envs.studies.adaptation, scripts/adapt.py) on a small run: the map
that learns on gets better, the frozen one stays put, the stale baselines are off by about the
change and the re-calibrated oracle is exact."""

from __future__ import annotations

import json

import cv2
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.cli import adapt as adapt_script
from envs.harness.training import RunConfig
from envs.studies.adaptation import MAP_CONTINUAL, MAP_STANDARD, AdaptConfig, adapt, pretrain
from learners.som.controller import VisuomotorSOM

from helpers import assert_drawn_png

COARSE = 0  # column of the coarse error: the one a camera change moves most
IMPROVED = 0.8  # the learning map's error after the run, at most this fraction of just after


@pytest.fixture(scope="module")
def run():
    run = RunConfig.of(
        env="RiacsReach-v0", trials=2000, lattice=(6, 4, 3), eval_every=2000, eval_trials=150
    )
    config = AdaptConfig(run, after_trials=400, every=200)
    som, _ = pretrain(config)
    return adapt(config, som)[0]


@pytest.mark.parametrize("name", [MAP_STANDARD, MAP_CONTINUAL])
def test_the_learning_map_gets_better_after_a_camera_change(run, name):
    just_after = run["after"]["map frozen"]["mean_mm"][COARSE]
    end = run["curves"][name][-1]["mean_mm"][COARSE]
    assert end < IMPROVED * just_after, (name, just_after, end)


def test_the_frozen_map_stays_put(run):
    assert run["after"]["map frozen (end)"] == run["after"]["map frozen"]
    assert run["curves"][MAP_STANDARD][0] == {"trial": 0, **run["after"]["map frozen"]}


def test_stale_baselines_miss_by_the_change_and_the_oracle_is_exact(run):
    for name in ("AnalyticIK stale", "JacobianIK stale"):
        assert run["before"][name]["mean_mm"][-1] < 1e-3  # exact before the change
        assert run["after"][name]["mean_mm"][-1] > 10.0  # a 5 cm, 3° camera change: cm errors
    assert run["after"]["AnalyticIK recalibrated"]["mean_mm"][-1] < 1e-3


def test_adapt_script_writes_results_plot_and_video(tmp_path):
    rows = adapt_script.main(
        ["--envs", "RiacsReach-v0", "--changes", "zoom", "--train-trials", "200",
         "--pre-every", "200", "--after", "100", "--every", "100", "--eval-trials", "20",
         "--video-trials", "1", "--out", str(tmp_path)]
    )  # fmt: skip
    folder = tmp_path / "RiacsReach-v0"
    result = json.loads((folder / "zoom.json").read_text())
    assert result["change"] == "focal length +5.0 %"
    assert [r["trial"] for r in result["curves"][MAP_CONTINUAL]] == [0, 100]
    assert rows == json.loads((tmp_path / "table.json").read_text())
    assert_drawn_png(folder / "curves.png")
    capture = cv2.VideoCapture(str(folder / "video_zoom.mp4"))
    ok, frame = capture.read()
    assert ok and frame.shape[1] == 3 * 320  # three phases side by side
    # A map carried from one run into another: warmed up in the new run, then changed.
    again = tmp_path / "again"
    adapt_script.main(
        ["--envs", "RiacsReach-v0", "--changes", "base", "--pretrained", str(tmp_path),
         "--warmup", "30", "--after", "20", "--every", "20", "--eval-trials", "5",
         "--video-trials", "0", "--out", str(again)]
    )  # fmt: skip
    carried = VisuomotorSOM.load(again / "RiacsReach-v0" / "pretrained.npz")
    assert carried.t + sum(carried.skipped.values()) == 200 + 30
    assert json.loads((again / "RiacsReach-v0" / "base.json").read_text())["change"] == (
        "base moved 50 mm"
    )
