"""Target sampling: one point at a time (a reach env's reset) draws exactly what the batch
sampler of the previous release drew, kept here as the reference."""

from __future__ import annotations

import numpy as np
import pytest

import models
from models import puma560, riacs  # noqa: F401  (getattr(models, name))

SEEDS = 1000  # generators per robot
DRAWS = 8  # resets per generator (an env draws from one generator across resets)


def reference_sample(workspace, rng: np.random.Generator, n: int) -> np.ndarray:
    """The sampler as released before the one-point path: rounds of 2 m + 8 candidates for the
    m points still missing, tested as a batch through the array inverse kinematics."""
    out = np.empty((0, 3))
    while len(out) < n:
        cand = rng.uniform(workspace.lower, workspace.upper, size=(2 * (n - len(out)) + 8, 3))
        out = np.concatenate([out, cand[workspace.contains(cand)]])
    return out[:n]


@pytest.mark.parametrize("name", ["riacs", "puma560"])
def test_one_point_draws_equal_the_batch_sampler(name):
    workspace = getattr(models, name).WORKSPACE
    for seed in range(SEEDS):
        new, old = np.random.default_rng(seed), np.random.default_rng(seed)
        for _ in range(DRAWS):
            np.testing.assert_array_equal(
                workspace.sample(new, 1), reference_sample(workspace, old, 1)
            )
        assert new.bit_generator.state == old.bit_generator.state  # the same draws consumed


@pytest.mark.parametrize("n", [2, 5, 300])
def test_batches_are_unchanged(n):
    new, old = np.random.default_rng(n), np.random.default_rng(n)
    np.testing.assert_array_equal(
        riacs.WORKSPACE.sample(new, n), reference_sample(riacs.WORKSPACE, old, n)
    )


@pytest.mark.parametrize("name", ["riacs", "puma560"])
def test_point_test_agrees_with_the_batch_test(name):
    """Inside and far outside the box: joint limits, no IK solution (too far, too near)."""
    workspace = getattr(models, name).WORKSPACE
    rng = np.random.default_rng(3)
    margin = 0.5 * (workspace.upper - workspace.lower)  # m
    points = rng.uniform(workspace.lower - margin, workspace.upper + margin, (20_000, 3))
    points[:10] = 0.0  # the base: no direction (RIACS: a division by zero)
    points[10] = np.nan
    batch = workspace.contains(points)
    one = np.array([workspace.contains_point(*p) for p in points.tolist()])
    np.testing.assert_array_equal(one, batch)
    assert 0.02 < batch.mean() < 0.98  # both answers are well represented


def test_env_reset_targets_are_the_reference_draws():
    import gymnasium as gym

    import envs  # noqa: F401

    env = gym.make("RiacsReach-v0", sensing="project", control="kinematic").unwrapped
    for seed in range(5):
        rng = np.random.default_rng(seed)
        env.reset(seed=seed)
        for _ in range(3):
            np.testing.assert_array_equal(
                env.data.mocap_pos[0], reference_sample(riacs.WORKSPACE, rng, 1)[0]
            )
            env.reset()
    env.close()
