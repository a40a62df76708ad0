"""Held out means held out: the evaluation stream never meets training's, for any pair of seeds.

The sets are drawn through the envs themselves (the reach targets, the grasp task's objects),
the way training runs and ``evaluate.py`` draw them, and compared point by point.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the envs)
from envs.harness import streams
from envs.harness.training import RunConfig

SEEDS = range(6)
TARGETS = 40


def _targets(env: gym.Env, n: int) -> np.ndarray:
    """The next ``n`` targets (n, 3) m the env draws (the grasp env: the object's frame and
    orientation, (n, 12))."""
    out = []
    for _ in range(n):
        _, info = env.reset()
        pose = info.get("target_pose")
        out.append(info["target_pos"] if pose is None else pose[:3].ravel())
    return np.array(out)


def _shared(a: np.ndarray, b: np.ndarray) -> int:
    """How many rows of ``a`` equal some row of ``b`` to 1e-12."""
    d = np.abs(a[:, None, :] - b[None, :, :]).max(axis=-1)
    return int((d < 1e-12).any(axis=1).sum())


@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaGrasp-v0"])
def test_training_and_evaluation_sets_are_disjoint_for_every_pair_of_seeds(env_id):
    config = {"env": env_id, "sensing": "project", "control": "kinematic"}
    training, evaluation = {}, {}
    for seed in SEEDS:
        run = RunConfig(**config, seed=seed, trials=TARGETS)
        for sets, stream in ((training, "training"), (evaluation, "evaluation")):
            env = run.make_env(stream)
            sets[seed] = _targets(env, TARGETS)
            env.close()
    # The check can fail: a stream drawn again repeats itself exactly ...
    env = RunConfig(**config, seed=0).make_env("evaluation")
    assert _shared(_targets(env, TARGETS), evaluation[0]) == TARGETS
    env.close()
    # ... and no evaluation target of any seed is a training target of any seed.
    for a in SEEDS:
        for b in SEEDS:
            assert _shared(evaluation[a], training[b]) == 0, (a, b)
            if a != b:
                assert _shared(evaluation[a], evaluation[b]) == 0, (a, b)


def test_training_stream_is_what_reset_with_a_seed_draws():
    """Runs trained before the streams existed resume unchanged: training is reset(seed=s)."""
    env = gym.make("RiacsReach-v0", sensing="project", control="kinematic")
    env.reset(seed=3)
    by_reset = _targets(env, 5)
    streams.seed_env(env, 3, "training")
    env.reset()  # make_env("training") draws the first target with reset(seed=...)
    np.testing.assert_array_equal(_targets(env, 5), by_reset)
    env.close()


def test_the_three_streams_differ_and_repeat():
    draws = {s: streams.generator(7, s).random(1000) for s in streams.STREAMS}
    for s in streams.STREAMS:
        np.testing.assert_array_equal(streams.generator(7, s).random(1000), draws[s])
        for t in streams.STREAMS:
            if s != t:
                assert not np.intersect1d(draws[s], draws[t]).size


@pytest.mark.parametrize("seed", [-1, 1.5, True, "0"])
def test_a_bad_seed_or_stream_is_refused_in_one_line(seed):
    with pytest.raises(ValueError, match="seed is"):
        streams.generator(seed, "evaluation")
    with pytest.raises(ValueError, match="unknown stream 'test'; valid: training"):
        streams.generator(0, "test")
