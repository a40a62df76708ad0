"""Recovery from a hidden marker (``SOMConfig.recover``): the moves by hand on a hand-set map,
a rendered scene where the arm hides its own marker after the coarse move, the evaluation's
counts, and a map saved in the middle of a recovery that goes on bit-identically. Learning in
the realistic setting (foveated rendering, servo moves): it improves with trials, measured by
the simulator's ground truth, and a stopped run resumes bit-identically."""

from __future__ import annotations

import json
import os
import signal

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401 - registers the reach envs
from envs.harness.checkpoint import CHECKPOINT_FILE
from envs.harness.evaluation import evaluate
from envs.harness.stopping import StopRequested
from envs.harness.training import METRICS_FILE, RunConfig, Trainer, initial_map
from envs.harness.trials import learn_from, run_trial
from learners.som.config import SOMConfig
from learners.som.controller import VisuomotorSOM, kernels
from learners.som.recovery import APPROACH_FRACTIONS, DETOUR_FRACTIONS

from helpers import SMALL_COORDS, forbid_the_exact_model, hand_set_map

LOW, HIGH = np.array([-5.0, -5.0]), np.array([5.0, 5.0])
#: Trials of the small RIACS map the scene uses (exact projection, kinematic moves: seconds).
MAP_TRIALS = 2000
#: reset(seed=SCENE_SEED) then a trial: the RIACS arm's links hide its marker from both cameras
#: at the target's pose (found by looking, with the map below: it stops after the coarse move).
SCENE_SEED = 201
KERNELS = ["numpy", *(["numba"] if kernels.available() else [])]


def _by_hand(theta_k: np.ndarray, a_k: np.ndarray, w_k: np.ndarray, x: np.ndarray) -> np.ndarray:
    return np.clip(theta_k + a_k @ (x - w_k), LOW, HIGH)


def _hand_map(**kw) -> VisuomotorSOM:
    """The hand-set map with the winner alone and fixed Ā: every move by hand."""
    return hand_set_map(LOW, HIGH, averaging="winner", abar="average", refine=False, **kw)


def test_without_recover_there_is_no_recovery_move():
    som = _hand_map()
    som.act(np.array([0.2, 0.9]))
    assert som.recover is False and som.recovery_move(np.array([0.2, 0.9]), 0) is None


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_detour_when_nothing_was_seen_aims_towards_the_middle_of_the_w(kernel):
    som = _hand_map(recover=True, kernel=kernel)
    w = np.array(SMALL_COORDS, dtype=float)
    theta = np.array([[0.1 * k, -0.2 * k] for k in range(6)])
    a = np.array([[[1.0 + k, 0.5], [0.0, 2.0 - 0.3 * k]] for k in range(6)])
    u = np.array([2.0, 1.2])  # beyond the lattice: the middle (1, 0.5) lies to its lower left
    som.act(u)
    for attempt, f in enumerate(DETOUR_FRACTIONS):
        goal = u + f * (np.array([1.0, 0.5]) - u)
        k = int(np.argmin(((w - goal) ** 2).sum(1)))
        np.testing.assert_allclose(
            som.recovery_move(u, attempt), _by_hand(theta[k], a[k], w[k], goal), rtol=1e-12
        )
    assert som.recovery_move(u, len(DETOUR_FRACTIONS)) is None
    # the next fine move corrects from the last detour: θ_d + A_s (u − v_d), s the winner of u
    v_d = np.array([1.1, 0.6])
    detour = som.recovery_move(u, 1)
    np.testing.assert_allclose(som.act(u, v_d), _by_hand(detour, a[5], v_d, u), rtol=1e-12)


@pytest.mark.parametrize("kernel", KERNELS)
def test_after_a_sighting_the_steps_shorten_from_the_last_pose_seen(kernel):
    som = _hand_map(recover=True, kernel=kernel)
    a_s = np.array([[4.0, 0.5], [0.0, 1.1]])  # A of neuron 3 at (1, 1), the winner of u
    u = np.array([1.1, 0.9])
    theta0 = som.act(u)
    v0 = np.array([0.7, 0.5])  # seen after the coarse move
    theta1 = som.act(u, v0)  # this fine move hid the marker
    np.testing.assert_allclose(theta1, _by_hand(theta0, a_s, v0, u), rtol=1e-12)
    for attempt, h in enumerate(APPROACH_FRACTIONS):
        goal = v0 + h * (u - v0)
        np.testing.assert_allclose(
            som.recovery_move(u, attempt), _by_hand(theta0, a_s, v0, goal), rtol=1e-12
        )
    assert som.recovery_move(u, len(APPROACH_FRACTIONS)) is None
    som.reset()
    with pytest.raises(ValueError, match="needs a coarse act"):
        som.recovery_move(u, 0)


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_recovered_step_refines_abar_with_the_move_it_sensed(kernel):
    """With ``refine``, the fine move after a step from the last pose seen takes the Broyden
    step of that sensed move (θ_s, v_s) -> (θ_d, v_d), as after any two sensed moves."""
    som = hand_set_map(LOW, HIGH, averaging="winner", abar="average", recover=True, kernel=kernel)
    a_s = np.array([[4.0, 0.5], [0.0, 1.1]])
    u, v0, v_d = np.array([1.1, 0.9]), np.array([0.7, 0.5]), np.array([0.95, 0.66])
    theta0 = som.act(u)
    som.act(u, v0)
    theta_d = som.recovery_move(u, 0)
    dth, dv = theta_d - theta0, v_d - v0
    abar = a_s + np.outer(dth - a_s @ dv, dv) / (dv @ dv)
    np.testing.assert_allclose(som.act(u, v_d), _by_hand(theta_d, abar, v_d, u), rtol=1e-12)


@pytest.fixture(scope="module")
def riacs_map() -> VisuomotorSOM:
    """A small RIACS map learned from exact projection with kinematic moves."""
    config = RunConfig(env="RiacsReach-v0", trials=MAP_TRIALS)
    env = config.make_env()
    som = initial_map(config, env)
    for _ in range(MAP_TRIALS):
        learn_from(som, run_trial(env, som, fine_moves=1, explore=True))
    env.close()
    return som


@pytest.fixture(scope="module")
def rendered():
    env = gym.make("RiacsReach-v0", sensing="foveated", control="kinematic")
    yield env
    env.close()


def test_the_arm_hiding_its_marker_after_the_coarse_move_no_longer_stops_the_trial(
    riacs_map, rendered, monkeypatch
):
    rendered.reset(seed=SCENE_SEED)
    stopped = run_trial(rendered, riacs_map, fine_moves=2)
    assert stopped.target_visible and len(stopped.distances) == 1  # MRS's loop stops here
    assert not np.isfinite(stopped.sensed_px[0]).any() and stopped.recovery_moves == 0

    forbid_the_exact_model(monkeypatch)  # recovery never uses the exact model
    rendered.reset(seed=SCENE_SEED)
    recovered = run_trial(rendered, riacs_map.with_config(recover=True), fine_moves=2)
    np.testing.assert_array_equal(recovered.target_pos, stopped.target_pos)
    np.testing.assert_array_equal(recovered.commands[0], stopped.commands[0])
    assert len(recovered.distances) == 3 and recovered.recovery_moves >= 1
    # ground truth from the simulator: the recovered trial ends far nearer than where the
    # stopped one stayed
    assert recovered.distances[-1] < 0.25 * stopped.distances[0]


def test_the_evaluation_counts_recovered_trials_and_their_moves(riacs_map, rendered):
    rendered.reset(seed=SCENE_SEED)
    plain = evaluate(rendered, riacs_map, trials=1, fine_moves=2).summary()
    rendered.reset(seed=SCENE_SEED)
    result = evaluate(rendered, riacs_map.with_config(recover=True), trials=1, fine_moves=2)
    assert plain["complete_trials"] == 0 and "recovered_trials" not in plain
    summary = result.summary()
    assert summary["complete_trials"] == 1 and summary["recovered_trials"] == 1
    assert summary["mean_recovery_moves"] == result.recovery_moves[0] >= 1
    assert summary["mean_mm"][-1] < 0.25 * plain["mean_mm"][-1]


def test_a_map_saved_mid_recovery_goes_on_bit_identically(riacs_map, tmp_path):
    som = riacs_map.with_config(recover=True)
    rng = np.random.default_rng(5)
    u = som.w[40] + rng.normal(0.0, 2.0, 4)
    som.act(u)
    som.act(u, u + rng.normal(0.0, 3.0, 4))  # seen after the coarse move
    back = VisuomotorSOM.load(som.save(tmp_path / "mid.npz"))
    assert back.recover and back.config == som.config
    for attempt in range(2):  # a step from the saved pose seen, then the fine move after it
        np.testing.assert_array_equal(back.recovery_move(u, attempt), som.recovery_move(u, attempt))
    v = u + rng.normal(0.0, 1.0, 4)
    np.testing.assert_array_equal(back.act(u, v), som.act(u, v))


def test_recover_is_stored_only_when_on_and_checked():
    assert "recover" not in SOMConfig().to_dict()  # maps without it keep their files
    assert SOMConfig.from_dict(SOMConfig(recover=True).to_dict()).recover is True
    with pytest.raises(ValueError, match=r"SOMConfig\.recover must be True or False"):
        SOMConfig(recover="yes")


#: A small run in the realistic setting: foveated rendering and servo moves.
REALISTIC = RunConfig.of(sensing="foveated", control="servo", trials=120, lattice=(4, 3, 2),
                      eval_every=60, eval_trials=20, seed=4)  # fmt: skip


def _run(trainer: Trainer, **kw) -> Trainer:
    try:
        trainer.run(checkpoint_every=1000, **kw)
    finally:
        trainer.close()
    return trainer


@pytest.fixture(scope="module")
def realistic_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("realistic")
    _run(Trainer(REALISTIC, out))
    return out


def test_a_map_learned_from_rendered_sensing_improves_with_trials(realistic_run):
    """Held-out distances are the simulator's ground truth, not what the cameras sensed."""
    rows = [json.loads(line) for line in (realistic_run / METRICS_FILE).read_text().splitlines()]
    assert [r["trial"] for r in rows] == [0, 60, 120]
    coarse = [r["mean_mm"][0] for r in rows]
    assert coarse[2] < coarse[1] < coarse[0] and coarse[2] < 0.3 * coarse[0], coarse
    assert rows[2]["mean_mm"][-1] < 0.7 * coarse[2]  # the fine moves correct further


def test_realistic_training_resumes_bit_identically(realistic_run, tmp_path):
    def interrupt(trial, running):
        if trial == 70:
            os.kill(os.getpid(), signal.SIGINT)  # a real signal, noted by the trainer's handler

    with pytest.raises(StopRequested):
        _run(Trainer(REALISTIC, tmp_path), progress=interrupt)
    _run(Trainer.resume(tmp_path))
    whole, resumed = (VisuomotorSOM.load(d / CHECKPOINT_FILE) for d in (realistic_run, tmp_path))
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(resumed, name), getattr(whole, name))
    assert (resumed.t, resumed.skipped) == (whole.t, whole.skipped)
    assert (tmp_path / METRICS_FILE).read_text() == (realistic_run / METRICS_FILE).read_text()
