"""The command-line programs on the grasp task, end to end on tiny runs: train, evaluate (the
position and orientation after every move, the exact pose IK floor beside), video, the
grasp-learning study, and the one-line errors for controllers of the other task."""

from __future__ import annotations

import itertools
import json

import cv2
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.cli import evaluate, grasp_learning, train, video
from envs.harness.grasp_film import HOLD_SECONDS
from envs.studies.grasp_learning import table
from envs.studies.grasp_learning_plot import PUBLISHED, figure
from learners.som.hierarchical import HierarchicalSOM
from learners.som.hierarchical_config import HierarchicalConfig
from models.puma560 import ARM_REACH

from helpers import assert_drawn_png, one_line_error, run_script


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("grasp")
    train.main(["--env", "PumaGrasp-v0", "--trials", "60", "--lattice", "3x2x2",
                "--orientation-lattice", "2", "--eval-every", "30", "--eval-trials", "5",
                "--out", str(out)])  # fmt: skip
    return out


def test_train_builds_the_hierarchical_map_with_the_lattices_given(run):
    som = HierarchicalSOM.load(run / "checkpoint.npz")
    assert som.config.position_lattice == (3, 2, 2) and som.config.orientation_lattice == (2,)
    rows = [json.loads(r) for r in (run / "metrics.jsonl").read_text().splitlines()]
    assert [r["trial"] for r in rows] == [0, 30, 60] and all("mean_deg" in r for r in rows)


def test_evaluate_gives_position_and_orientation_beside_the_floor(run, tmp_path, capsys):
    summary = evaluate.main(["--run", str(run), "--targets", "12", "--fine-moves", "3", "--compare",
                             "pose_ik", "pose_jacobian", "--out", str(tmp_path)])  # fmt: skip
    text = capsys.readouterr().out
    som, floor, jacobian = summary["controllers"]
    assert [som["controller"], floor["controller"]] == ["hierarchical som", "pose_ik"]
    assert "pose_jacobian" in text
    heads = [r for r in text.splitlines() if r.startswith("controller")]
    assert [h.split()[:4] for h in heads] == [["controller", "move", "mean", "[mm]"],
                                              ["controller", "move", "mean", "[deg]"]]  # fmt: skip
    assert ">1mm|1deg" in heads[1] and max(len(r) for r in text.splitlines()) <= 100
    for row in (floor, jacobian):  # exact projection, exact IK: no error at all
        assert max(row["mean_mm"]) < 1e-6 and max(row["mean_deg"]) < 1e-6
    assert som["mean_mm"][-1] > 1e-3 and som["mean_deg"][-1] > 1e-3
    # % of reach is mm over the PUMA's reach: an independent unit conversion
    np.testing.assert_allclose(
        som["mean_percent_reach"], np.array(som["mean_mm"]) / (10 * ARM_REACH), rtol=1e-3
    )
    lines = text.splitlines()
    starts = [i for i, r in enumerate(lines) if r.startswith("hierarchical som ")]
    position, orientation = starts  # its first line in each table
    for k in range(4):  # coarse, then fine 1-3: one line each in both tables
        cells = lines[position + k].split()[-4:]  # mean mm, % reach, median mm, max mm
        assert cells[:2] == [f"{som['mean_mm'][k]:.3f}", f"{som['mean_percent_reach'][k]:.4f}"]
        cells = lines[orientation + k].split()[-4:]  # mean deg, median deg, max deg, tail
        assert cells[0] == f"{som['mean_deg'][k]:.3f}"
        assert cells[3] == f"{100 * som['tail_fraction'][k]:.2f}%"
    assert lines[position + 3].split()[-6:-4] == ["fine", "3"]
    assert json.loads((tmp_path / "evaluation.json").read_text())["env"] == "PumaGrasp-v0"
    assert not list(tmp_path.glob("*.png"))  # the reach plots do not apply


def test_video_films_the_hand_moving_onto_the_object(run, tmp_path):
    out = tmp_path / "grasp.mp4"
    video.main(["--env", "PumaGrasp-v0", "--controller", str(run), "--compare", "pose_ik",
                "--trials", "1", "--fine-moves", "1", "--fps", "10",
                "--out", str(out)])  # fmt: skip
    capture, frames = cv2.VideoCapture(str(out)), []
    while (frame := capture.read())[0]:
        frames.append(frame[1])
    hold = round(HOLD_SECONDS * 10)
    assert len(frames) > 3 * hold  # the new object, then two servo moves, each held
    for frame in frames:
        assert frame.std() > 20
    changes = sum(np.abs(a.astype(int) - b).mean() > 0.1 for a, b in itertools.pairwise(frames))
    assert changes > 3  # the arm moves during the servo moves, not one picture per stage


@pytest.mark.parametrize(
    ("script", "args", "says"),
    [
        ("evaluate", ["--env", "PumaGrasp-v0", "--controller", "analytic"], "reach controller"),
        ("evaluate", ["--env", "RiacsReach-v0", "--controller", "pose_ik"], "needs the grasp env"),
        ("train", ["--orientation-lattice", "2"], "--orientation-lattice is for PumaGrasp-v0"),
        ("train", ["--env", "PumaGrasp-v0", "--protocol", "brause"], "do not apply"),
    ],
)
def test_controllers_and_options_of_the_other_task_are_one_line_errors(
    script, args, says, tmp_path
):
    result = run_script(script, *args, "--out", str(tmp_path / "out"))
    assert says in one_line_error(result)


def test_grasp_learning_plots_the_tables_means_beside_the_published_rows(tmp_path, capsys):
    config = HierarchicalConfig(position_lattice=(2, 2, 1), orientation_lattice=(1,))
    rows = table(seed=0, config=config, trials_per_leaf=(1.0, 4.0), test_targets=6)
    fig = figure(rows, "test")
    position, orientation = fig.axes
    lines = [line for line in position.get_lines() if line.get_label() == "fine 3"]
    np.testing.assert_allclose(lines[0].get_ydata(), [r.position_pct[3] for r in rows[:2]])
    lines = [line for line in orientation.get_lines() if line.get_label() == "coarse"]
    np.testing.assert_allclose(lines[0].get_ydata(), [r.orientation_deg[0] for r in rows[:2]])
    published = {line.get_label(): line.get_ydata()[0] for line in orientation.get_lines()}
    assert all(published[name] == deg for name, _, deg, _ in PUBLISHED)
    assert position.get_xscale() == "log"
    out = tmp_path / "g.png"
    grasp_learning.main(["--targets", "3", "--trials-per-leaf", "0.01", "--out", str(out)])
    assert "| PoseIK (floor) |" in capsys.readouterr().out
    assert_drawn_png(out)


def test_reach_map_options_on_a_pose_map_are_one_line_errors(run, tmp_path):
    result = run_script("evaluate", "--run", str(run), "--recover", "--targets", "2",
                        "--out", str(tmp_path))  # fmt: skip
    assert "takes --no-refine and --no-backtrack" in one_line_error(result)


def test_the_rl_comparison_trains_the_pose_map_on_the_pose_env():
    """compare_rl's map method on PumaGrasp-v0 builds the hierarchical map, and its held-out
    ground-truth distance falls with the budget (the env's distances, not the map's own)."""
    from envs.studies.rl_comparison import train_map

    kwargs = {"sensing": "project", "control": "kinematic"}
    # 6 144 env steps: one training trial (two moves) per leaf of the default 3 072-leaf map
    curve = train_map("PumaGrasp-v0", kwargs, seed=0, budget=6144, points=[2, 6144], targets=30)
    assert curve.steps[0] <= 4 and curve.steps[-1] >= 6144
    assert curve.mean_m[-1] < 0.1 * curve.mean_m[0], curve.mean_m
