"""The grasp task in the harness: orientation errors per move carried forward like distances,
summaries in degrees only for grasp envs, and training runs of the hierarchical map that
checkpoint and resume bit for bit."""

from __future__ import annotations

import json
import os
import signal

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.harness.checkpoint import CHECKPOINT_FILE, check_map_fits, load_map, read_unit
from envs.harness.evaluation import Evaluation, carried_orientation, evaluate
from envs.harness.stopping import StopRequested
from envs.harness.training import (
    METRICS_FILE,
    TRAINING_PAIRS,
    RunConfig,
    Trainer,
    initial_grasp_map,
)
from envs.harness.trials import Trial, learn_from
from envs.studies.grasp_oracle import PoseOracle
from envs.studies.sweep_grid import cell_name
from learners.base import Controller
from learners.persistence import CheckpointError
from learners.som.controller import VisuomotorSOM
from learners.som.hierarchical import HierarchicalSOM
from models.puma560.grasp import READY, orientation_angle

POSE = RunConfig.of(env="PumaGrasp-v0", trials=60, lattice=(3, 2, 2), orientation_lattice=(2,),
                 eval_every=20, eval_trials=8, fine_moves=2, seed=2)  # fmt: skip
#: The keys of a reach summary, in order, as before the grasp envs (the demo compares them).
REACH_KEYS = ["trials", "complete_trials", "complete_fraction", "made_fraction", "mean_mm",
              "median_mm", "p95_mm", "mean_percent_reach", "mean_px", "median_px", "p95_px",
              "microseconds_per_query"]  # fmt: skip


class Still(Controller):
    """Always commands the taught pose ``READY``."""

    def act(self, u, v=None, explore=False):
        return READY.copy()


def test_orientation_errors_are_carried_forward_from_where_a_trial_stopped():
    trial = Trial(np.zeros(12), start_orientation_error=0.5)
    trial.orientation_errors = [0.4, 0.3]  # stopped after the first fine move
    np.testing.assert_array_equal(carried_orientation(trial, 4), [0.4, 0.3, 0.3, 0.3])
    never = Trial(np.full(12, np.nan), start_orientation_error=0.5)
    np.testing.assert_array_equal(carried_orientation(never, 3), [0.5, 0.5, 0.5])


def test_summaries_give_degrees_for_pose_envs_only():
    n, moves = 5, 3
    rng = np.random.default_rng(0)
    reach = Evaluation(rng.random((n, moves)), rng.random((n, moves)), np.zeros((n, 3)),
                       np.zeros((n, 3)), 1.0, 1e-6)  # fmt: skip
    assert list(reach.summary()) == REACH_KEYS
    radians = rng.random((n, moves))
    pose = Evaluation(reach.distances, reach.pixel_errors, reach.target_pos, reach.reached, 1.0,
                      1e-6, orientation_errors=radians)  # fmt: skip
    summary = pose.summary()
    assert list(summary)[:-1] == [*REACH_KEYS[:-1], "mean_deg", "median_deg", "p95_deg",
                                  "max_mm", "max_deg", "tail_fraction"]  # fmt: skip
    # The tail: trials over 1 mm or 1°, counted by hand.
    off = [
        sum(1 for i in range(n) if reach.distances[i, k] > 1e-3 or radians[i, k] > np.pi / 180)
        for k in range(moves)
    ]
    np.testing.assert_allclose(summary["tail_fraction"], np.array(off) / n, atol=1e-5)
    np.testing.assert_allclose(summary["max_mm"], 1e3 * reach.distances.max(axis=0), atol=1e-4)
    np.testing.assert_allclose(summary["mean_deg"], radians.mean(axis=0) * 180 / np.pi, atol=1e-5)
    np.testing.assert_allclose(
        summary["median_deg"], np.median(radians, axis=0) * 180 / np.pi, atol=1e-5
    )


def test_evaluate_reports_the_hands_orientation_error_against_the_closed_form():
    """A controller that holds the taught pose: its orientation error after every move is the
    angle between the closed-form hand orientation at READY and the object's."""
    env = gym.make("PumaGrasp-v0", sensing="project", control="kinematic")
    env.reset(seed=7)
    result = evaluate(env, Still(), trials=6, fine_moves=1)
    env.reset(seed=7)
    objects = []
    for _ in range(6):
        env.reset()
        objects.append(env.unwrapped.target_pose())
    env.close()
    hand = PoseOracle().hand_pose(READY)
    expected = [orientation_angle(hand[:3, :3], o[:3, :3]) for o in objects]
    assert result.orientation_errors.shape == (6, 2)
    for k in range(2):
        np.testing.assert_allclose(result.orientation_errors[:, k], expected, atol=1e-6)


def test_reach_runs_and_their_sweep_cells_keep_their_names():
    """The names main gave these cells before the grasp envs (their hash covers the config)."""
    assert cell_name(RunConfig()) == "riacs_12x7x4_mrs_mrs_True_project_kinematic_0_55963bc8"
    puma = RunConfig.of(env="PumaReach-v0", lattice=(4, 3, 2), seed=3)
    assert cell_name(puma) == "puma_4x3x2_mrs_mrs_True_project_kinematic_3_00af8fb5"


def test_run_configs_refuse_options_of_the_other_map():
    with pytest.raises(ValueError, match="orientation_lattice is for the grasp envs"):
        RunConfig.of(orientation_lattice=(2, 2))
    with pytest.raises(ValueError, match=r"option\(s\) protocol do not apply"):
        RunConfig.of(env="PumaGrasp-v0", protocol="brause")
    config = RunConfig.of(env="PumaGrasp-v0", lattice=(4, 4, 3)).map
    assert config.position_lattice == (4, 4, 3) and config.orientation_lattice == (2, 2, 2)


def _train(config, out, **kw):
    trainer = Trainer(config, out)
    try:
        trainer.run(**kw)
    finally:
        trainer.close()
    return trainer


def _arrays(path):
    som = load_map(path)
    assert isinstance(som, HierarchicalSOM)
    return som.w_pos, som.w_ori, som.theta, som.A, som.df_cov, som.t


@pytest.fixture(scope="module")
def unbroken(tmp_path_factory):
    out = tmp_path_factory.mktemp("pose")
    _train(POSE, out, checkpoint_every=1000)
    return out


def test_the_pose_run_trains_the_hierarchical_map_from_the_taught_pose(unbroken):
    som = HierarchicalSOM.load(unbroken / CHECKPOINT_FILE)
    assert som.config.position_lattice == (3, 2, 2) and som.config.orientation_lattice == (2,)
    # its schedules run over the run's trials; a trial learns unless a marker went unseen
    assert som.config.t_max == POSE.trials and 0.9 * POSE.trials <= som.t <= POSE.trials
    env = POSE.make_env()
    start = initial_grasp_map(POSE, env)
    env.close()
    np.testing.assert_array_equal(start.theta, np.broadcast_to(READY, start.theta.shape))
    np.testing.assert_array_equal(start.A, 0.0)
    rows = [json.loads(r) for r in (unbroken / METRICS_FILE).read_text().splitlines()]
    assert [r["trial"] for r in rows] == [0, 20, 40, 60]
    # learning helped both the position and the orientation after the last move
    assert rows[-1]["mean_mm"][-1] < rows[0]["mean_mm"][-1]
    assert rows[-1]["mean_deg"][-1] < rows[0]["mean_deg"][-1]


def test_pose_run_resumes_after_sigint_bit_identically(unbroken, tmp_path):
    def interrupt(trial, running):
        if trial == 33:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(StopRequested):
        _train(POSE, tmp_path, checkpoint_every=1000, progress=interrupt)
    assert read_unit(tmp_path / CHECKPOINT_FILE)[0]["trial"] == 33
    trainer = Trainer.resume(tmp_path)
    trainer.run(checkpoint_every=1000)
    trainer.close()
    for a, b in zip(
        _arrays(unbroken / CHECKPOINT_FILE), _arrays(tmp_path / CHECKPOINT_FILE), strict=True
    ):
        np.testing.assert_array_equal(a, b)
    assert (tmp_path / METRICS_FILE).read_text() == (unbroken / METRICS_FILE).read_text()


def test_a_map_of_the_other_task_is_refused(unbroken, tmp_path):
    grasp_env = gym.make("PumaGrasp-v0", sensing="project", control="kinematic")
    reach_env = gym.make("PumaReach-v0", sensing="project", control="kinematic", joints=6)
    reach_map = VisuomotorSOM(
        reach_env.unwrapped.joint_lower, reach_env.unwrapped.joint_upper, lattice=(2, 2, 2), rng=0
    )
    reach_map.save(tmp_path / "reach.npz")
    try:
        with pytest.raises(CheckpointError, match="needs a HierarchicalSOM"):
            check_map_fits(tmp_path / "reach.npz", load_map(tmp_path / "reach.npz"), grasp_env)
        pose_map = load_map(unbroken / CHECKPOINT_FILE)
        with pytest.raises(CheckpointError, match="needs a VisuomotorSOM"):
            check_map_fits(unbroken / CHECKPOINT_FILE, pose_map, reach_env)
    finally:
        grasp_env.close()
        reach_env.close()


def test_a_pose_run_keeps_its_orientation_range_and_old_runs_read_as_the_ball(tmp_path):
    """RunConfig stores the objects' orientation range by its spelling, the env it makes draws
    from it, and a stored grasp run from before the field existed reads as the 30° ball it was
    trained on; a reach run refuses the field."""
    narrow = RunConfig(env="PumaGrasp-v0", sensing="project", orientations="ball:30.0")
    assert narrow.orientations == "ball:30" and RunConfig.from_stored(narrow.to_stored()) == narrow
    env = narrow.make_env()
    assert env.unwrapped.orientations.spec() == "ball:30"
    env.close()
    assert RunConfig(env="PumaGrasp-v0").orientations == "yaw:90,tilt:45"
    stored = RunConfig(env="PumaGrasp-v0").to_stored()
    assert stored["training_pairs"] == TRAINING_PAIRS == 4
    del stored["orientations"], stored["training_pairs"]
    old = RunConfig.from_stored(stored)  # a run stored before the fields: as it was trained
    assert old.orientations == "ball:30" and old.training_pairs == 1
    with pytest.raises(ValueError, match=r"training_pairs is 0; it takes an integer in 1\.\.8"):
        RunConfig(env="PumaGrasp-v0", training_pairs=0)
    with pytest.raises(ValueError, match="training_pairs is for the grasp envs"):
        RunConfig(env="PumaReach-v0", training_pairs=2)
    with pytest.raises(ValueError, match="orientations is for the grasp envs"):
        RunConfig(env="RiacsReach-v0", orientations="ball:30")
    with pytest.raises(ValueError, match="tilt is 95°"):
        RunConfig(env="PumaGrasp-v0", orientations="yaw:10,tilt:95")


class Recorder(Controller):
    """Records what ``learn`` was given; refuses (returns False) the pairs listed in ``refuse``."""

    def __init__(self, refuse: tuple[int, ...] = ()) -> None:
        self.calls: list[tuple] = []
        self.refuse = refuse

    def act(self, u, v=None, explore=False):
        return READY.copy()

    def learn(self, u, theta0, v0, theta1, v1, coarse=True):
        self.calls.append((u, theta0, v0, theta1, v1, coarse))
        return len(self.calls) - 1 not in self.refuse


def test_learn_from_gives_consecutive_pairs_with_the_same_target():
    """Pair k is (θ_k, v_k) -> (θ_k+1, v_k+1), the first with the learner's default (the coarse
    rule), the later ones with coarse=False; no more pairs than the trial's moves allow; the
    count is of the pairs learned."""
    trial = Trial(np.arange(12.0))
    trial.commands = [np.full(6, float(k)) for k in range(4)]  # coarse and 3 fine moves
    trial.sensed_px = [np.full(12, 10.0 + k) for k in range(4)]
    one = Recorder()
    assert learn_from(one, trial) == 1 and len(one.calls) == 1 and one.calls[0][5] is True
    many = Recorder(refuse=(1,))
    assert learn_from(many, trial, pairs=5) == 2  # 3 pairs made, the second refused
    assert [c[5] for c in many.calls] == [True, False, False]
    for k, (u, theta0, v0, theta1, v1, _) in enumerate(many.calls):
        np.testing.assert_array_equal(u, trial.target_px)
        np.testing.assert_array_equal(theta0, np.full(6, float(k)))
        np.testing.assert_array_equal(theta1, np.full(6, float(k + 1)))
        np.testing.assert_array_equal(v0, np.full(12, 10.0 + k))
        np.testing.assert_array_equal(v1, np.full(12, 11.0 + k))
    assert learn_from(Recorder(), Trial(np.zeros(12)), pairs=3) == 0  # no move: nothing
    with pytest.raises(ValueError, match="pairs"):
        learn_from(Recorder(), trial, pairs=0)
