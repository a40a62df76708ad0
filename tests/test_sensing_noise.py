"""The map's ``sensing_noise`` option (the Widrow-Hoff step corrected for the errors of the
sensed v0 and v1): the step by hand on both kernels, the published step left bit for bit when it
is off, the option stored and checked, a map saved (or a run stopped) with it on that goes on
bit-identically, and learning from whole rendered images with it, measured by the simulator's
ground truth."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

import envs  # noqa: F401 - registers the reach envs
from envs.harness.checkpoint import CHECKPOINT_FILE
from envs.harness.evaluation import evaluate
from envs.harness.stopping import StopRequested
from envs.harness.training import METRICS_FILE, RunConfig, Trainer, initial_map
from envs.harness.trials import learn_from, run_trial
from envs.studies.sweep_grid import cell_name
from learners.som.config import SOMConfig
from learners.som.controller import VisuomotorSOM, kernels
from models import riacs

from helpers import hand_set_map
from helpers import riacs_pixels as pixels

KERNELS = ["numpy", *(["numba"] if kernels.available() else [])]
LOW, HIGH = np.array([-1.0, -2.0]), np.array([1.0, 2.0])
TRIAL = {
    "u": np.array([1.2, 0.1]),
    "theta0": np.array([0.3, -0.4]),
    "v0": np.array([1.0, 0.3]),
    "theta1": np.array([0.35, -0.3]),
    "v1": np.array([1.1, 0.2]),
}
#: The sweep cell name of ``RunConfig()``, computed with the code before ``sensing_noise``.
DEFAULT_CELL = "riacs_12x7x4_mrs_mrs_True_project_kinematic_0_55963bc8"
#: Held-out targets of the rendered run: a seed no training env uses.
HELD_OUT_SEED = 70_006


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("sigma", [0.0, 0.02])  # 0: the published step; 5σ = 0.1 < |Δv| = 0.14
def test_the_step_of_a_adds_three_sigma_squared_a_by_hand(kernel, sigma):
    """A* = A_s + ((Δθ − A_s Δv) Δv^T + 3σ² A_s) / |Δv|², then A_r += ε' h' (A* − A_r): with
    the winner alone and ε' = 1 the winner's A becomes A* exactly (σ = 0: the published
    Widrow-Hoff step of Ritter, Martinetz & Schulten)."""
    som = hand_set_map(
        LOW, HIGH, averaging="winner", eps_out=1.0, sigma_out=0.01, sensing_noise=sigma,
        kernel=kernel,
    )  # fmt: skip
    a = som.A.copy()
    u, th0, v0, th1, v1 = TRIAL.values()
    s = int(np.argmin([np.hypot(*(u - w)) for w in som.w]))
    dv = v1 - v0
    a_star = a[s] + (np.outer((th1 - th0) - a[s] @ dv, dv) + 3 * sigma**2 * a[s]) / (dv @ dv)
    assert som.learn(**TRIAL) is True
    np.testing.assert_allclose(som.A[s], a_star, rtol=1e-13)


@pytest.mark.parametrize("kernel", KERNELS)
def test_with_it_on_trials_whose_dv_is_within_five_sigma_are_skipped(kernel):
    """|Δv| = 0.14 here: learned with σ = 0.028 (5σ = 0.14 just below), skipped with 0.029."""
    dv = np.linalg.norm(TRIAL["v1"] - TRIAL["v0"])
    for sigma, learned in ((0.99 * dv / 5, True), (1.01 * dv / 5, False)):
        som = hand_set_map(LOW, HIGH, sensing_noise=sigma, kernel=kernel)
        a = som.A.copy()
        assert som.learn(**TRIAL) is learned
        assert som.skipped["small_dv"] == (0 if learned else 1)
        assert np.array_equal(som.A, a) is not learned


def _trained(kernel: str, **options) -> VisuomotorSOM:
    """200 trials on the report's RIACS cameras (pure numpy pixels), seeded."""
    som = VisuomotorSOM(
        riacs.LOWER, riacs.UPPER, t_max=200, rng=11, input_high=[320] * 4, kernel=kernel, **options
    )
    targets = np.random.default_rng(3).uniform(riacs.LOWER + 0.1, riacs.UPPER - 0.1, (200, 3))
    for target in targets:
        u = pixels(target)
        som.reset()
        theta0 = som.act(u)
        v0 = pixels(theta0)
        theta1 = som.act(u, v0, explore=True)
        som.learn(u, theta0, v0, theta1, pixels(theta1))
    return som


def _arrays(som: VisuomotorSOM) -> list[np.ndarray]:
    return [som.w, som.theta, som.A]


@pytest.mark.parametrize("kernel", KERNELS)
def test_off_by_default_the_map_learns_the_published_step_bit_for_bit(kernel):
    """Off (the default) and 0 are one code path: the same 200 trials give the same map, bit for
    bit, in this run; 0.1 changes it. The step itself is checked by hand above (σ = 0)."""
    assert SOMConfig().sensing_noise == 0.0
    default, zero, on = (
        _trained(kernel, **kw) for kw in ({}, {"sensing_noise": 0.0}, {"sensing_noise": 0.1})
    )
    for a, b in zip(_arrays(default), _arrays(zero), strict=True):
        assert np.array_equal(a, b)
    assert not all(map(np.array_equal, _arrays(default), _arrays(on)))


def test_the_kernels_agree_with_it_on():
    if "numba" not in KERNELS:
        pytest.skip("numba not installed (pip install 'visuomotor[fast]')")
    a, b = _trained("numpy", sensing_noise=0.1), _trained("numba", sensing_noise=0.1)
    for name in ("w", "theta", "A"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-9, atol=1e-12)


def test_sensing_noise_is_stored_only_when_on_and_checked():
    assert "sensing_noise" not in SOMConfig().to_dict()  # maps without it keep their files
    assert SOMConfig.from_dict(SOMConfig(sensing_noise=0.1).to_dict()).sensing_noise == 0.1
    with pytest.raises(ValueError, match=r"SOMConfig\.sensing_noise must be >= 0"):
        SOMConfig(sensing_noise=-0.1)
    with pytest.raises(ValueError, match=r"SOMConfig\.sensing_noise must be a finite float"):
        SOMConfig(sensing_noise=float("nan"))


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_map_saved_with_it_on_goes_on_bit_identically(kernel, tmp_path):
    targets = np.random.default_rng(5).uniform(riacs.LOWER + 0.1, riacs.UPPER - 0.1, (160, 3))

    def train(som: VisuomotorSOM, part: np.ndarray) -> None:
        for target in part:
            u = pixels(target)
            som.reset()
            theta0 = som.act(u)
            v0 = pixels(theta0)
            theta1 = som.act(u, v0, explore=True)
            som.learn(u, theta0, v0, theta1, pixels(theta1))

    def new() -> VisuomotorSOM:
        return VisuomotorSOM(
            riacs.LOWER, riacs.UPPER, t_max=160, rng=2, input_high=[320] * 4, kernel=kernel,
            sensing_noise=0.1,
        )  # fmt: skip

    whole, first = new(), new()
    train(whole, targets)
    train(first, targets[:70])
    first.save(tmp_path / "checkpoint.npz")
    second = VisuomotorSOM.load(tmp_path / "checkpoint.npz", kernel=kernel)
    assert second.sensing_noise == 0.1
    train(second, targets[70:])
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(second, name), getattr(whole, name))
    assert second.rng.bit_generator.state == whole.rng.bit_generator.state


def test_a_map_learning_from_whole_rendered_images_with_it_improves_with_trials():
    """Whole 320×240 rendered images, kinematic moves; the held-out distances are the
    simulator's ground truth (``info["distance"]``), not what the cameras sensed."""
    config = RunConfig.of(sensing="render", trials=300, lattice=(4, 3, 2), seed=6)
    env, held_out = config.make_env(), config.make_env()
    try:
        som = initial_map(config, env, sensing_noise=0.1)
        held_out.reset(seed=HELD_OUT_SEED)
        before = evaluate(held_out, som, 20, 1).distances.copy()  # (20, 2) m
        held_out.reset(seed=HELD_OUT_SEED)  # the same targets again
        for _ in range(config.trials):
            learn_from(som, run_trial(env, som, fine_moves=1, explore=True))
        after = evaluate(held_out, som, 20, 1).distances
    finally:
        env.close()
        held_out.close()
    coarse_before, coarse_after = np.nanmean(before[:, 0]), np.nanmean(after[:, 0])
    assert som.t > 250
    assert coarse_after < 0.4 * coarse_before, (coarse_before, coarse_after)
    assert np.nanmean(after[:, 1]) < 0.8 * coarse_after  # the fine move corrects further


def test_a_run_with_it_resumes_bit_identically_and_runs_without_it_keep_their_files(tmp_path):
    config = RunConfig.of(trials=80, lattice=(4, 3, 2), eval_every=40, eval_trials=5, seed=3,
                       sensing_noise=0.1)  # fmt: skip
    whole = tmp_path / "whole"
    trainer = Trainer(config, whole)
    try:
        trainer.run(checkpoint_every=1000)
    finally:
        trainer.close()

    def interrupt(trial, running):
        if trial == 50:
            os.kill(os.getpid(), signal.SIGINT)  # a real signal, noted by the trainer's handler

    part = tmp_path / "part"
    trainer = Trainer(config, part)
    try:
        with pytest.raises(StopRequested):
            trainer.run(checkpoint_every=1000, progress=interrupt)
    finally:
        trainer.close()
    trainer = Trainer.resume(part)
    try:
        trainer.run(checkpoint_every=1000)
    finally:
        trainer.close()
    a, b = (VisuomotorSOM.load(d / CHECKPOINT_FILE) for d in (whole, part))
    assert b.sensing_noise == 0.1
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name))
    assert (part / METRICS_FILE).read_text() == (whole / METRICS_FILE).read_text()
    # off (the default) it is neither stored nor in a sweep cell's name
    assert "sensing_noise" not in RunConfig().to_stored()
    assert cell_name(RunConfig()) == DEFAULT_CELL  # as named before the option existed
    assert cell_name(RunConfig()) != cell_name(config)
