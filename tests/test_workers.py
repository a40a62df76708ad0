"""Training with workers (``envs/harness/workers.py``, ``train.py --workers N``): one worker is
the one-process training bit for bit; N >= 2 workers give the map of rounds written out here
(a second implementation), the same for every N and every run, after a worker was killed
mid-round, and after SIGKILL, SIGTERM and SIGINT of a real ``train.py`` at random moments.
"""

from __future__ import annotations

import json
import os
import pickle
import signal
import threading

import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.cli import train
from envs.harness.evaluation import evaluate
from envs.harness.training import RunConfig, Trainer, initial_map
from envs.harness.trials import learn_from, run_trial
from envs.harness.workers import (
    ROUND_TRIALS,
    InProcessPool,
    WorkerPool,
    round_end,
    shares,
    trial_rngs,
)
from envs.limits import MAX_WORKERS

#: A small run: the default sensing (projection) and control (kinematic), a tiny lattice.
SMALL = {"lattice": (4, 3, 2), "seed": 3, "trials": 300, "eval_every": 100, "eval_trials": 10}


def _trained(tmp_path, name, pool=None, **settings):
    """A finished Trainer of SMALL with ``settings`` in ``tmp_path/name`` (closed), its map."""
    trainer = Trainer(RunConfig.of(**(SMALL | settings)), tmp_path / name)
    if pool is not None:
        trainer.make_pool = pool
    try:
        trainer.run()
    finally:
        trainer.close()
    return trainer


def _same_maps(a, b):
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(a.learned, name), getattr(b.learned, name), name)
    assert a.t == b.t and a.skipped == b.skipped


def _checkpoint(out):
    with np.load(out / "checkpoint.npz") as z:
        return {k: z[k] for k in z.files}


def test_shares_and_rounds_cover_every_trial_once():
    for first, end, n in [(0, 64, 2), (64, 100, 3), (5, 6, 4), (0, 1000, 7)]:
        parts = shares(first, end, n)
        assert [k for part in parts for k in part] == list(range(first, end))
        sizes = [len(part) for part in parts]
        assert max(sizes) - min(sizes) <= 1 and len(parts) == min(n, end - first)
    trial, ends = 0, []
    while trial < 1030:
        trial = round_end(trial, 1030, 250, 64)
        ends.append(trial)
    # every multiple of 64 and of 250 below 1030, and 1030: nothing else
    wanted = sorted({*range(64, 1030, 64), *range(250, 1030, 250), 1030})
    assert ends == wanted


def test_the_trials_generators_are_none_of_the_streams():
    """Trial k's two generators against the training, held-out and validation streams (and
    each other): no two draw the same numbers."""
    from envs.harness.streams import STREAMS, generator

    for seed in (0, 5):
        draws = [tuple(generator(seed, stream).random(4)) for stream in STREAMS]
        for k in (0, 1, 2, 1000):
            draws += [tuple(g.random(4)) for g in trial_rngs(seed, k)]
        assert len(set(draws)) == len(draws)


def test_one_worker_is_the_one_process_training_bit_for_bit(tmp_path):
    """train.py --workers 1 writes the checkpoint of train.py without the flag, and both are a
    loop of run_trial and learn_from written out here."""
    common = ["--lattice", "4x3x2", "--trials", "150", "--eval-every", "50", "--eval-trials",
              "5", "--seed", "3"]  # fmt: skip
    train.main([*common, "--out", str(tmp_path / "plain")])
    train.main([*common, "--workers", "1", "--out", str(tmp_path / "one")])
    plain, one = _checkpoint(tmp_path / "plain"), _checkpoint(tmp_path / "one")
    assert sorted(plain) == sorted(one)
    for key in plain:
        np.testing.assert_array_equal(plain[key], one[key], key)
    assert (tmp_path / "plain" / "metrics.jsonl").read_bytes() == (
        tmp_path / "one" / "metrics.jsonl"
    ).read_bytes()

    config = RunConfig.of(**(SMALL | {"trials": 150}))
    env = config.make_env()
    som = initial_map(config, env)
    for _ in range(config.trials):
        learn_from(som, run_trial(env, som, fine_moves=1, explore=True), 1)
    env.close()
    np.testing.assert_array_equal(som.learned.theta, plain["theta"])
    np.testing.assert_array_equal(som.learned.A, plain["A"])
    np.testing.assert_array_equal(som.learned.w, plain["w"])


def _rounds_by_hand(config):
    """The map of ``config`` (workers >= 2) trained in rounds without the harness's workers:
    each round's trials run with a frozen copy of the map from the round's start, each with the
    generators of its index, then learned in their order."""
    env = config.make_env()
    som = initial_map(config, env)
    trial = 0
    while trial < config.trials:
        end = round_end(trial, config.trials, config.eval_every, ROUND_TRIALS)
        frozen = pickle.loads(pickle.dumps(som))
        collected = []
        for k in range(trial, end):
            env.unwrapped.np_random, frozen.rng = trial_rngs(config.seed, k)
            collected.append(run_trial(env, frozen, fine_moves=1, explore=True))
        for t in collected:
            learn_from(som, t, 1, stale=True)
        trial = end
    env.close()
    return som


def test_workers_give_the_map_of_rounds_for_every_n_and_run(tmp_path):
    """Two worker processes twice, three in this process: the same map, the one of the rounds
    written out here, and not the one-process training's."""
    first = _trained(tmp_path, "first", workers=2)
    second = _trained(tmp_path, "second", workers=2)
    three = _trained(tmp_path, "three", pool=InProcessPool, workers=3)
    _same_maps(first.som, second.som)
    _same_maps(first.som, three.som)
    _same_maps(first.som, _rounds_by_hand(RunConfig.of(**(SMALL | {"workers": 2}))))
    assert (tmp_path / "first" / "metrics.jsonl").read_bytes() == (
        tmp_path / "second" / "metrics.jsonl"
    ).read_bytes()
    assert first.running == second.running
    plain = _trained(tmp_path, "plain", workers=1)
    assert not np.array_equal(plain.som.learned.theta, first.som.learned.theta)


def _one_process_row(config, som):
    """The held-out summary of ``som`` evaluated in one process, as a run of one worker does."""
    env = config.make_env("evaluation")
    summary = evaluate(env, pickle.loads(pickle.dumps(som)), config.eval_trials,
                       config.fine_moves).summary()  # fmt: skip
    env.close()
    del summary["microseconds_per_query"]
    return summary


@pytest.mark.parametrize("pool", [WorkerPool, InProcessPool])
def test_workers_evaluate_as_one_process_does(tmp_path, pool):
    """The workers share out the held-out evaluations (11 targets: uneven shares, the second
    starting in the middle of the stream); each row is the one-process evaluation's, before
    training and after."""
    config = RunConfig.of(**(SMALL | {"workers": 2, "trials": 200, "eval_trials": 11}))
    trainer = Trainer(config, tmp_path / "run")
    trainer.make_pool = pool
    try:
        untrained = _one_process_row(config, trainer.som)
        assert {k: v for k, v in trainer.held_out().items() if k in untrained} == untrained
        ran_here = trainer.pool.pids == {os.getpid()}  # the workers' (two shares, any process)
        assert ran_here == (pool is InProcessPool), trainer.pool.pids
        trainer.run()
        trained = _one_process_row(config, trainer.som)
        assert {k: v for k, v in trainer.held_out().items() if k in trained} == trained
    finally:
        trainer.close()
    rows = (tmp_path / "run" / "metrics.jsonl").read_text().splitlines()
    assert {k: v for k, v in json.loads(rows[-1]).items() if k in trained} == trained


def test_a_worker_killed_mid_round_is_started_again_and_the_round_redone(tmp_path):
    """SIGKILL of a worker at a moment drawn after the first round: the pool starts again, the
    round is redone, and the map is that of a run without the kill."""
    settings = {"workers": 2, "trials": 640, "eval_every": 640}
    reference = _trained(tmp_path, "reference", pool=InProcessPool, **settings)
    trainer = Trainer(RunConfig.of(**(SMALL | settings)), tmp_path / "killed")
    _run_killing_a_worker(trainer, np.random.default_rng(35))
    assert trainer.pool is None
    _same_maps(trainer.som, reference.som)
    assert trainer.spent is not None and trainer.spent.restarts >= 1


def _run_killing_a_worker(trainer, rng):
    """Run ``trainer`` to its end (closed after), one of its workers sent SIGKILL at a moment
    drawn from ``rng`` 0-0.2 s after its first round."""
    delay = float(rng.uniform(0.0, 0.2))  # s into the next rounds
    killed: list[int] = []

    def progress(trial, running):
        if not killed and trainer.pool is not None:
            pid = min(trainer.pool.pids)
            killed.append(pid)
            threading.Timer(delay, os.kill, (pid, signal.SIGKILL)).start()

    try:
        trainer.run(progress=progress)
    finally:
        trainer.close()
    assert killed


@pytest.mark.parametrize("value", ["0", "-1", "1.5", "two", str(MAX_WORKERS + 1)])
def test_a_bad_number_of_workers_is_one_line(tmp_path, capsys, value):
    with pytest.raises(SystemExit) as stopped:
        train.main(["--workers", value, "--out", str(tmp_path / "run")])
    assert stopped.value.code == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert len(lines) == 1 and "--workers" in lines[0] and repr(value) in lines[0], lines
    assert not (tmp_path / "run").exists()


def test_keep_arm_with_workers_is_refused_in_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as stopped:
        train.main(["--workers", "2", "--keep-arm", "--out", str(tmp_path / "run")])
    assert stopped.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--keep-arm" in err and "--workers" in err, err
    with pytest.raises(ValueError, match="keep_arm") as refused:
        RunConfig(keep_arm=True, workers=2)
    assert "\n" not in str(refused.value)
    with pytest.raises(ValueError, match="reach maps only") as refused:
        RunConfig(env="PumaGrasp-v0", workers=2)
    assert "\n" not in str(refused.value)
    for bad in (0, MAX_WORKERS + 1, 2.0, True):
        with pytest.raises(ValueError, match="workers"):
            RunConfig(workers=bad)


def test_a_run_of_one_worker_stores_no_workers_entry():
    """Runs trained before workers existed keep their files and sweep cells their names."""
    assert "workers" not in RunConfig().to_stored()
    assert RunConfig(workers=2).to_stored()["workers"] == 2
    assert RunConfig.from_stored(RunConfig(workers=2).to_stored()).workers == 2


def _map(**options):
    from learners.som.controller import VisuomotorSOM

    lower, upper = np.array([-1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0])
    return VisuomotorSOM(lower, upper, rng=7, lattice=(3, 3, 2), t_max=100, **options)


def test_a_stale_trial_moves_the_coarse_target_by_what_its_command_missed():
    """learn_stale = learn with θ* moved by θ0 − the map's command now: the winner's θ moves by
    ε' (θ0 − θ0_now) more than learn moves it (h = 1 at the winner); a θ0 that is the map's
    command now learns exactly as learn does; the fine-error target is learn's."""
    u, v0, v1 = (
        np.array([0.5, 0.4, 0.6, 0.5]),
        np.array([0.45, 0.42, 0.55, 0.5]),
        np.array([0.52, 0.38, 0.61, 0.47]),
    )
    plain, stale = _map(kernel="numpy"), _map(kernel="numpy")
    now = plain.act_batch(u[None])[0]
    theta0 = now + np.array([0.05, -0.02, 0.03])
    theta1 = theta0 + np.array([0.01, 0.02, -0.01])
    s = plain.winner(u)
    before = plain.theta[s].copy()
    eps_out = plain.params()[2]
    assert plain.learn(u, theta0, v0, theta1, v1) and stale.learn_stale(u, theta0, v0, theta1, v1)
    moved_more = (stale.theta[s] - before) - (plain.theta[s] - before)
    np.testing.assert_allclose(moved_more, eps_out * (theta0 - now), rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(stale.A, plain.A)
    np.testing.assert_array_equal(stale.w, plain.w)

    same, reference = _map(kernel="numpy"), _map(kernel="numpy")
    same.learn_stale(u, now, v0, theta1, v1)
    reference.learn(u, now, v0, theta1, v1)
    np.testing.assert_array_equal(same.theta, reference.theta)

    fine, fine_reference = _map(theta_target="fine-error"), _map(theta_target="fine-error")
    fine.learn_stale(u, theta0, v0, theta1, v1)
    fine_reference.learn(u, theta0, v0, theta1, v1)
    np.testing.assert_allclose(fine.theta, fine_reference.theta, rtol=1e-12, atol=1e-15)
