"""Training with workers as Ray actors (``train.py --workers N --address ADDR``,
``envs/harness/ray_workers.py``) on a local Ray instance: the checkpoint of local worker
processes and the map of the rounds written out in tests/test_workers.py, bit for bit; an actor
killed mid-round is replaced and its round redone; a run stopped on Ray continues in local
processes, and one stopped there continues on Ray, to the unbroken run's checkpoint. And, in
real processes: the mistakes of --address (a bad address, one worker, Ray missing) are one line;
workers without --address never import Ray.
"""

from __future__ import annotations

import os
import signal
import socket

import numpy as np
import pytest
from test_workers import (
    SMALL,
    _checkpoint,
    _rounds_by_hand,
    _run_killing_a_worker,
    _same_maps,
    _trained,
)

import envs  # noqa: F401  (GL back-end before mujoco)
from envs import sizes
from envs.cli import train
from envs.harness.ray_cluster import LOCAL, AddressError
from envs.harness.stopping import StopRequested
from envs.harness.training import METRICS_FILE, RunConfig, Trainer
from envs.harness.workers import InProcessPool

from helpers import one_line_error, run_script

NO_RAY = "ray not installed (make test-sweep installs it)"
#: Two rounds of 100 trials with two workers (a round ends at each held-out evaluation).
TWO_ROUNDS = SMALL | {"trials": 200, "workers": 2}
#: train.py's arguments for TWO_ROUNDS.
ARGV = [
    f"--{key.replace('_', '-')}={sizes.format_lattice(value) if key == 'lattice' else value}"
    for key, value in TWO_ROUNDS.items()
]


def _same_runs(a, b):
    """The run folders ``a`` and ``b`` hold the same checkpoint (every entry, the run's
    configuration among them) and the same held-out rows, byte for byte."""
    first, second = _checkpoint(a), _checkpoint(b)
    assert sorted(first) == sorted(second)
    for key in first:
        np.testing.assert_array_equal(first[key], second[key], key)
    assert (a / METRICS_FILE).read_bytes() == (b / METRICS_FILE).read_bytes()


@pytest.fixture(scope="module")
def ray_module():
    """The ``ray`` module; the test is skipped, saying why, without it."""
    return pytest.importorskip("ray", reason=NO_RAY)


@pytest.fixture(scope="module")
def local_run(tmp_path_factory):
    """TWO_ROUNDS trained by train.py with local worker processes: its folder."""
    out = tmp_path_factory.mktemp("local") / "run"
    train.main([*ARGV, "--out", str(out)])
    return out


def test_ray_actors_give_the_checkpoint_of_local_workers_and_the_map_of_rounds(
    ray_module, local_run, tmp_path
):
    """train.py --address local (first in this file: Ray is started and shut down by the run)."""
    ray = ray_module
    assert not ray.is_initialized()
    train.main([*ARGV, "--address", LOCAL, "--out", str(tmp_path / "ray")])
    assert not ray.is_initialized()  # the run started Ray, and shut it down
    _same_runs(tmp_path / "ray", local_run)
    by_hand = _rounds_by_hand(RunConfig.of(**TWO_ROUNDS))
    on_ray = _checkpoint(tmp_path / "ray")
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(by_hand.learned, name), on_ray[name], name)


@pytest.fixture(scope="module")
def ray_local(ray_module):
    """A local Ray instance of 2 CPUs for the module's remaining tests (the runs use it and
    leave it running)."""
    from envs.harness.ray_cluster import start_ray

    start_ray(LOCAL, num_cpus=2)
    yield ray_module
    ray_module.shutdown()


def test_an_actor_killed_mid_round_is_replaced_and_its_round_redone(ray_local, tmp_path):
    """SIGKILL of an actor's process at a moment drawn after the first of three rounds: new
    actors redo the round, and the map is that of the rounds run in this process."""
    settings = {"workers": 2}
    reference = _trained(tmp_path, "reference", pool=InProcessPool, **settings)
    trainer = Trainer(RunConfig.of(**(SMALL | settings)), tmp_path / "killed", address=LOCAL)
    _run_killing_a_worker(trainer, np.random.default_rng(36))
    assert ray_local.is_initialized()  # Ray started by the fixture stays
    _same_maps(trainer.som, reference.som)
    assert trainer.spent is not None and trainer.spent.restarts >= 1


@pytest.mark.parametrize(("first", "then"), [(LOCAL, None), (None, LOCAL)])
def test_a_run_continues_bit_for_bit_with_or_without_address(
    ray_local, local_run, tmp_path, first, then
):
    """Stopped after its first round with workers on Ray (or local processes), resumed by
    train.py --resume without --address (or with it): the unbroken local run's checkpoint."""
    trainer = Trainer(RunConfig.of(**TWO_ROUNDS), tmp_path / "run", address=first)

    def stop(trial, running):
        raise StopRequested(signal.SIGINT)

    try:
        with pytest.raises(StopRequested):
            trainer.run(progress=stop)
    finally:
        trainer.close()
    assert trainer.trial == 100
    train.main(["--resume", "--out", str(tmp_path / "run"), *(["--address", then] if then else [])])
    _same_runs(tmp_path / "run", local_run)


# ---- mistakes, without Ray

#: Stands in for a missing Ray: an importable ``ray`` that fails as an absent one does.
NO_RAY_MODULE = 'raise ModuleNotFoundError("No module named \'ray\'", name="ray")\n'
#: (program, arguments, what the line must name, Ray hidden)
MISTAKES = [
    ("train", ["--workers", "2", "--address", "nowhere"], "--address", False),
    ("train", ["--workers", "2", "--address", "head:99999"], "--address", False),
    ("train", ["--address", "auto"], "--workers", False),  # one worker: nothing to place
    ("train", ["--workers", "2", "--address", "auto"], ".[sweep]", True),
    ("sweep", ["--grid", "robot=riacs", "--address", "head:"], "--address", False),
    ("sweep", ["--grid", "robot=riacs"], ".[sweep]", True),
]


def _without_ray(folder):
    """The environment of a process that finds no Ray (NO_RAY_MODULE first on its path)."""
    folder.mkdir()
    (folder / "ray.py").write_text(NO_RAY_MODULE)
    return os.environ | {
        "PYTHONPATH": os.pathsep.join([str(folder), os.environ.get("PYTHONPATH", "")])
    }


@pytest.mark.parametrize(("name", "args", "named", "hidden"), MISTAKES)
def test_an_address_mistake_is_one_line_with_status_2_and_creates_nothing(
    name, args, named, hidden, tmp_path
):
    env = _without_ray(tmp_path / "hidden") if hidden else None
    result = run_script(name, *args, "--out", "run", cwd=tmp_path, env=env, timeout=120)
    line = one_line_error(result)
    assert named in line, line
    assert not (tmp_path / "run").exists()


def _closed_port() -> int:
    """A port of this machine on which nothing listens (one the system just handed out)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.mark.parametrize("hidden", [False, True])
@pytest.mark.parametrize("name", ["train", "sweep"])
def test_an_address_where_no_head_answers_is_one_line_and_creates_nothing(name, hidden, tmp_path):
    """Where ``ray.init`` would wait without end (nothing listens at the head's port), the run
    is refused before any work, Ray installed (if it is here) or not."""
    address = f"127.0.0.1:{_closed_port()}"
    args = ["--workers", "2"] if name == "train" else ["--grid", "robot=riacs"]
    env = _without_ray(tmp_path / "hidden") if hidden else None
    result = run_script(name, *args, "--address", address, "--out", "run", cwd=tmp_path,
                        env=env, timeout=120)  # fmt: skip
    line = one_line_error(result)
    assert f"no Ray head answers at {address}" in line, line
    assert not (tmp_path / "run").exists()


def test_workers_without_address_never_import_ray(tmp_path):
    """train.py --workers 2 trains in a process that finds no Ray."""
    args = ["--lattice", "3x2x2", "--trials", "20", "--eval-trials", "5", "--workers", "2"]
    env = _without_ray(tmp_path / "hidden")
    result = run_script("train", *args, "--out", "run", cwd=tmp_path, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "trained 20 trials" in result.stdout


def test_the_trainer_refuses_an_address_before_any_work(tmp_path):
    """The Python API's refusals: not a Ray address; a run of one worker."""
    with pytest.raises(AddressError, match="not a Ray address"):
        Trainer(RunConfig.of(**TWO_ROUNDS), tmp_path / "bad", address="nowhere")
    with pytest.raises(AddressError, match="1 worker"):
        Trainer(RunConfig.of(**(TWO_ROUNDS | {"workers": 1})), tmp_path / "one", address=LOCAL)
    assert not any((tmp_path / name).exists() and any((tmp_path / name).iterdir())
                   for name in ("bad", "one"))  # fmt: skip
