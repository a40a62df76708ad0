"""Target sampling: the points lie in the workspace, are spread uniformly over it (counts in
sub-boxes against their share of its volume, the box's mean and variance), follow the documented
draw order, and the point test agrees with the batch test."""

from __future__ import annotations

import numpy as np
import pytest

import models
from models import puma560, riacs

CELLS = 2  # sub-boxes per axis of the bounding box for the uniformity test
GRID = 48  # quadrature points per axis for each sub-box's share of the workspace's volume
SPARE = 8  # candidates a round draws beyond 2 per missing point (Workspace.sample's docstring)


def _cell_of(workspace, points: np.ndarray) -> np.ndarray:
    """Index (N,) of the sub-box of the bounding box that holds each point."""
    frac = (points - workspace.lower) / (workspace.upper - workspace.lower)
    ijk = np.minimum((frac * CELLS).astype(int), CELLS - 1)
    return np.ravel_multi_index(ijk.T, (CELLS,) * 3)


def _volume_shares(workspace) -> np.ndarray:
    """Share (CELLS³,) of the workspace's volume in each sub-box, by the midpoint rule on a
    regular grid (no random numbers)."""
    steps = (np.arange(GRID) + 0.5) / GRID
    axes = [lo + (hi - lo) * steps for lo, hi in zip(workspace.lower, workspace.upper, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    counts = np.bincount(_cell_of(workspace, grid[workspace.contains(grid)]), minlength=CELLS**3)
    return counts / counts.sum()


def _assert_reachable(points: np.ndarray) -> None:
    """RIACS: the joint angles of each point lie in the joint ranges and the report's forward
    kinematics (robot3df) takes them back to the point."""
    q = riacs.WORKSPACE.ik(points)
    assert np.all((q >= riacs.LOWER) & (q <= riacs.UPPER))
    back = np.array([riacs.robot3df(riacs.LINK1, riacs.LINK2, *angles) for angles in q])
    np.testing.assert_allclose(back, points, atol=1e-9)


@pytest.mark.parametrize("one_at_a_time", [False, True])
def test_riacs_targets_are_reachable_and_uniform_over_the_reachable_set(one_at_a_time):
    n, rng = 6000, np.random.default_rng(11)
    workspace = riacs.WORKSPACE
    if one_at_a_time:  # a reach env's resets
        points = np.concatenate([workspace.sample(rng, 1) for _ in range(n)])
    else:
        points = workspace.sample(rng, n)
    assert points.shape == (n, 3)
    _assert_reachable(points)
    share = _volume_shares(workspace)
    seen = np.bincount(_cell_of(workspace, points), minlength=CELLS**3) / n
    # Binomial spread of each count (5 sd) and the midpoint rule's error at the curved border.
    allowed = 5 * np.sqrt(share * (1 - share) / n) + 0.01
    assert np.all(np.abs(seen - share) <= allowed), (seen, share)


def test_box_targets_have_the_mean_and_variance_of_a_uniform_box():
    workspace = puma560.WORKSPACE
    n = 20_000
    points = workspace.sample(np.random.default_rng(5), n)
    assert np.all((points >= workspace.lower) & (points <= workspace.upper))
    width = workspace.upper - workspace.lower
    # U(a, b): mean (a + b)/2, variance (b − a)²/12; tolerances 5 standard errors.
    mean_se = width / np.sqrt(12 * n)
    np.testing.assert_array_less(np.abs(points.mean(0) - (workspace.lower + workspace.upper) / 2),
                                 5 * mean_se)  # fmt: skip
    var_se = width**2 / 12 * np.sqrt(0.8 / n)  # Var(s²) = σ⁴(μ4/σ⁴ − 1)/n, μ4/σ⁴ = 9/5 for U
    np.testing.assert_array_less(np.abs(points.var(0) - width**2 / 12), 5 * var_se)


@pytest.mark.parametrize("name", ["riacs", "puma560"])
def test_one_point_is_the_first_inside_of_the_documented_rounds(name):
    """A round for m missing points draws 2 m + 8 candidates lower + (upper − lower)·u, u three
    consecutive rng.random() doubles each; the point is the first candidate inside, and the
    generator ends after whole rounds."""
    workspace = getattr(models, name).WORKSPACE
    for seed in range(200):
        rng, by_hand = np.random.default_rng(seed), np.random.default_rng(seed)
        for _ in range(4):
            point = workspace.sample(rng, 1)[0]
            while True:
                u = by_hand.random((2 + SPARE, 3))
                candidates = workspace.lower + (workspace.upper - workspace.lower) * u
                inside = np.flatnonzero(workspace.contains(candidates))
                if inside.size:
                    np.testing.assert_array_equal(point, candidates[inside[0]])
                    break
        assert rng.bit_generator.state == by_hand.bit_generator.state


def test_same_seed_same_targets_other_seed_other_targets():
    draw = lambda seed: riacs.WORKSPACE.sample(np.random.default_rng(seed), 50)  # noqa: E731
    np.testing.assert_array_equal(draw(1), draw(1))
    assert not np.any(np.all(draw(1) == draw(2), axis=1))


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


def test_env_reset_targets_are_reachable_and_drawn_from_the_reset_seed():
    import gymnasium as gym

    import envs  # noqa: F401

    env = gym.make("RiacsReach-v0", sensing="project", control="kinematic").unwrapped
    targets = []
    for seed in (0, 1, 0):
        env.reset(seed=seed)
        targets.append(env.data.mocap_pos[0].copy())
        env.reset()
        targets.append(env.data.mocap_pos[0].copy())
    env.close()
    _assert_reachable(np.array(targets))
    np.testing.assert_array_equal(targets[:2], targets[4:])  # the same seed, the same targets
    assert not np.array_equal(targets[0], targets[2])
