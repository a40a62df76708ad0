"""Training trials collected by worker processes for one learner (``train.py --workers N``).

A run with N >= 2 workers trains in rounds. Each round the learner sends its map to the workers;
each worker runs its share of the round's trials with that map, in its own env, and sends back
what the trials saw (:class:`~envs.harness.trials.Trial`); the learner learns from them in the
order of their indices. Nothing a worker does depends on the trials it ran before: trial k
draws its target and its exploratory moves from generators of (seed, k) (:func:`trial_rngs`),
and its map is the one of the round's start. So the learned map depends on the seed and the
round size only, not on N or on which worker ran which trial, and a round is redone exactly
after a kill of the learner or of a worker.

Workers are processes of the ``spawn`` context (:class:`WorkerPool`), or Ray actors
(:mod:`envs.harness.ray_workers`, ``--address``): each builds its env (and the renderer's
context) itself, from the run's configuration. :class:`RoundPool` is what they share: the map
sent, the shares, a round redone after a worker died. The run's held-out evaluations are shared
out the same way (:func:`evaluate_share`): each worker runs a consecutive share of the held-out
trials, starting where one process evaluating them all would be in the stream, so the rows are
those of the one-process evaluation, bit for bit.
"""

from __future__ import annotations

import itertools
import multiprocessing
import multiprocessing.connection
import os
import pickle
import signal
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_EXCEPTION, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.harness.streams import seed_env
from envs.harness.trials import Trial, run_trial
from learners.persistence import quoted

#: Trials of a round: the staleness of a worker's map, in trials, at the end of a round. Chosen
#: by measuring the held-out errors against the round size (docs/decisions.md, "Workers").
ROUND_TRIALS = 256
#: Restarts of the workers within one round before the run gives up.
MAX_RESTARTS = 3
#: s between the learner's checks for a stop signal while the workers run a round.
POLL_SECONDS = 0.05
#: The first spawn key of the training trials' generators with workers (the streams of
#: ``envs.harness.streams`` take (), (1,) and (2,)).
TRIALS_KEY = 3
#: What a worker sends back for its share of a round: its pid, its seconds spent on the
#: trials, the trials.
Share = tuple[int, float, list[Trial]]


class WorkerError(RuntimeError):
    """The workers kept dying: a round could not be collected."""


def trial_rngs(seed: int, k: int) -> tuple[np.random.Generator, np.random.Generator]:
    """The generators of training trial k (0-based) of a run of ``seed`` with workers: the env's
    (the target) and the map's (the exploratory moves), ``SeedSequence(seed)`` with the spawn
    keys (TRIALS_KEY, k, 0) and (TRIALS_KEY, k, 1): beside the streams of
    ``envs.harness.streams`` (keys (), (1,), (2,)), never one of them. (``SeedSequence([seed,
    k])`` is not: a trailing 0 word mixes like no word, so its child 1 for k = 0 would be the
    held-out stream.)"""
    env_seq, map_seq = (
        np.random.SeedSequence(seed, spawn_key=(TRIALS_KEY, k, child)) for child in (0, 1)
    )
    return np.random.default_rng(env_seq), np.random.default_rng(map_seq)


def collect(env: Any, som: Any, seed: int, indices: Sequence[int], pairs: int) -> list[Trial]:
    """Run training trials ``indices`` with ``som`` (not learning), each from the home pose with
    its own generators (:func:`trial_rngs`); ``pairs`` fine moves each."""
    trials = []
    for k in indices:
        env.unwrapped.np_random, som.rng = trial_rngs(seed, k)
        trials.append(run_trial(env, som, fine_moves=pairs, keep_arm=False, explore=True))
    return trials


def round_end(trial: int, trials: int, eval_every: int, round_trials: int = ROUND_TRIALS) -> int:
    """Where the round from ``trial`` ends: at the next multiple of ``round_trials``, of
    ``eval_every`` (a held-out evaluation sees the map of its trial) or at ``trials``, whichever
    comes first. Checkpoints fall between rounds; their interval does not move the rounds."""
    step = round_trials - trial % round_trials
    to_eval = eval_every - trial % eval_every
    return min(trial + step, trial + to_eval, trials)


def shares(first: int, end: int, workers: int) -> list[range]:
    """Trials first .. end - 1 cut into ``workers`` consecutive shares as equal as they can be
    (empty shares left out)."""
    n = end - first
    cuts = [first + n * i // workers for i in range(workers + 1)]
    return [range(a, b) for a, b in itertools.pairwise(cuts) if b > a]


# -- the worker processes ----------------------------------------------------------------------

_ENV: Any = None  # a worker's env, built by _start_worker


def _start_worker(config: Any) -> None:
    """In a new worker: ignore SIGINT (a Ctrl-C at the terminal reaches the whole process group;
    the learner stops the run between rounds), end with the learner (a learner killed by
    SIGKILL leaves no worker behind) and build the run's env."""
    global _ENV
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_exit_with, args=(parent.sentinel,), daemon=True).start()
    import envs  # noqa: F401  (registers the envs in this process)

    _ENV = config.make_env()


def _exit_with(sentinel: int) -> None:
    """Wait until the process of ``sentinel`` has ended, then end this one."""
    multiprocessing.connection.wait([sentinel])
    os._exit(0)


def timed_collect(env: Any, blob: bytes, seed: int, indices: Sequence[int], pairs: int) -> Share:
    """:func:`collect` with the map pickled in ``blob``, as a worker runs its share: (its pid,
    seconds spent on the trials, the trials)."""
    start = time.perf_counter()
    trials = collect(env, pickle.loads(blob), seed, indices, pairs)
    return os.getpid(), time.perf_counter() - start, trials


def evaluate_share(env: Any, blob: bytes, seed: int, indices: range, fine_moves: int) -> Share:
    """Held-out trials ``indices`` of the evaluation stream of ``seed`` with the map pickled in
    ``blob`` (not learning), ``fine_moves`` fine moves each, in ``env`` (the run's, whatever it
    ran before): its generator set to the stream's start and moved past the targets of the
    trials before ``indices``, so each trial gets the target it gets in a one-process
    evaluation. (its pid, seconds spent on the trials, the trials)."""
    start = time.perf_counter()
    som = pickle.loads(blob)
    seed_env(env, seed, "evaluation")
    env.unwrapped.skip_targets(indices.start)
    trials = [run_trial(env, som, fine_moves) for _ in indices]
    return os.getpid(), time.perf_counter() - start, trials


#: The tasks a worker runs, by name: (env, map blob, seed, trial indices, pairs or fine moves)
#: -> its :data:`Share`.
COLLECT, EVALUATE = "collect", "evaluate"
TASKS: dict[str, Callable[[Any, bytes, int, range, int], Share]] = {
    COLLECT: timed_collect,
    EVALUATE: evaluate_share,
}


def _in_worker(task: str, blob: bytes, seed: int, indices: range, moves: int) -> Share:
    """A task of a worker process, in its env."""
    return TASKS[task](_ENV, blob, seed, indices, moves)


@dataclass
class Collected:
    """What the workers spent: seconds of trials summed over the workers, trials run, restarts
    after a worker died; and the learner's seconds spent sending them its map."""

    worker_seconds: float = 0.0
    trials: int = 0
    restarts: int = 0
    send_seconds: float = 0.0  # the learner's: pickling its map for the workers


class WorkerDied(Exception):
    """A worker died while it ran its share of a round (the message says how)."""


class RoundPool(ABC):
    """Workers that run a round's trials, each share with a copy of the map of the round's
    start (:func:`timed_collect`): the rounds' bookkeeping. Subclasses run the shares
    (:meth:`_run`, raising :class:`WorkerDied` when a worker died) and start their workers again
    (:meth:`_restart`); a dead worker's round is redone with new workers, at most MAX_RESTARTS
    times per round."""

    def __init__(self, config: Any, workers: int) -> None:
        self.config, self.workers = config, workers
        self.spent = Collected()
        self.pids: set[int] = set()  # the workers that ran the last round's shares

    #: Where a dead worker's error is to be read (in the error after MAX_RESTARTS).
    errors_shown = "see their error above"

    def collect(
        self, som: Any, first: int, end: int, pairs: int, check: Callable[[], None]
    ) -> list[Trial]:
        """Trials first .. end - 1 run with (a copy of) ``som``, in order. ``check`` is called
        every POLL_SECONDS while the workers run and before a restart: it may raise to abandon
        the round (it is redone when the run resumes; :meth:`close` ends the workers).

        Raises:
            WorkerError: the workers died MAX_RESTARTS + 1 times in this round.
        """
        parts = shares(first, end, self.workers)
        what = f"the round of trials {first}..{end - 1}"
        results = self._share_out(COLLECT, som, parts, pairs, check, what)
        self.spent.worker_seconds += sum(seconds for _, seconds, _ in results)
        self.spent.trials += end - first
        return [trial for _, _, trials in results for trial in trials]

    def evaluate(
        self, som: Any, trials: int, fine_moves: int, check: Callable[[], None]
    ) -> list[Trial]:
        """Held-out trials 0 .. trials - 1 of the run's evaluation stream with (a copy of)
        ``som``, in order: the trials of a one-process evaluation (:func:`evaluate_share`).
        ``check`` and the errors as for :meth:`collect` (an abandoned evaluation is redone when
        the run resumes)."""
        parts = shares(0, trials, self.workers)
        results = self._share_out(EVALUATE, som, parts, fine_moves, check, "an evaluation")
        return [trial for _, _, share in results for trial in share]

    def _share_out(
        self,
        task: str,
        som: Any,
        parts: list[range],
        moves: int,
        check: Callable[[], None],
        what: str,
    ) -> list[Share]:
        """``task`` (of :data:`TASKS`) run on ``parts`` by the workers, each with the map
        ``som`` as it is now; a worker's death redoes it with new workers."""
        start = time.perf_counter()
        blob = pickle.dumps(som)
        self.spent.send_seconds += time.perf_counter() - start
        last = WorkerDied()
        for _attempt in range(MAX_RESTARTS + 1):
            try:
                results = self._run(task, blob, parts, moves, check)
            except WorkerDied as died:
                last = died
                check()
                self._restart()
                self.spent.restarts += 1
                continue
            self.pids = {pid for pid, _, _ in results}
            return results
        raise WorkerError(
            f"the workers died {MAX_RESTARTS + 1} times in {what} (last: {quoted(last)}); "
            f"{self.errors_shown}, or run with --workers 1"
        )

    @abstractmethod
    def _run(
        self, task: str, blob: bytes, parts: list[range], moves: int, check: Callable[[], None]
    ) -> list[Share]:
        """``task`` on each of ``parts`` run by a worker with the map in ``blob`` (``moves``:
        the task's pairs or fine moves), calling ``check`` every POLL_SECONDS; the shares'
        results in the order of ``parts``."""

    @abstractmethod
    def _restart(self) -> None:
        """End the workers and start new ones."""

    @abstractmethod
    def close(self) -> None:
        """End the workers, also in the middle of a round (abandoned: a stopped run redoes it
        when it resumes)."""


class WorkerPool(RoundPool):
    """N local worker processes that run a round's trials (``spawn`` context; each builds the
    run's env from ``config``). A worker that dies mid-round takes the round with it: the pool
    is started again and the round redone."""

    def __init__(self, config: Any, workers: int) -> None:
        super().__init__(config, workers)
        self._executor = self._start()

    def _start(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_start_worker,
            initargs=(self.config,),
        )

    def _run(
        self, task: str, blob: bytes, parts: list[range], moves: int, check: Callable[[], None]
    ) -> list[Share]:
        seed = self.config.seed
        try:
            futures = [
                self._executor.submit(_in_worker, task, blob, seed, part, moves) for part in parts
            ]
            while not all(f.done() for f in futures):
                wait(futures, timeout=POLL_SECONDS, return_when=FIRST_EXCEPTION)
                check()
                if any(f.done() and f.exception() is not None for f in futures):
                    break
            return [f.result() for f in futures]
        except BrokenProcessPool as exc:
            raise WorkerDied(str(exc)) from None

    def _restart(self) -> None:
        self._executor.shutdown(wait=True, cancel_futures=True)
        self._executor = self._start()

    def close(self) -> None:
        processes = getattr(self._executor, "_processes", None) or {}  # the executor's own
        for process in list(processes.values()):
            process.terminate()
        self._executor.shutdown(wait=True, cancel_futures=True)


class InProcessPool(RoundPool):
    """The rounds of :class:`WorkerPool` run in this process, one env for all shares: the same
    trials (they do not depend on who runs them). For measurements that need no second core
    (the round size's) and for tests."""

    def __init__(self, config: Any, workers: int) -> None:
        super().__init__(config, workers)
        self._env = config.make_env()

    def _run(
        self, task: str, blob: bytes, parts: list[range], moves: int, check: Callable[[], None]
    ) -> list[Share]:
        run = TASKS[task]
        return [run(self._env, blob, self.config.seed, part, moves) for part in parts]

    def _restart(self) -> None:  # nothing dies here
        pass

    def close(self) -> None:
        self._env.close()
