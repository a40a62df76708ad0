"""Training trials collected by Ray actors for one learner (``train.py --workers N --address
ADDR``): the rounds of :mod:`envs.harness.workers` with an actor per worker, on a cluster or a
local Ray instance, giving the same trials and so the same map as local worker processes.

Each actor builds the run's env from its configuration at its first share and runs its shares
(a round's trials, or held-out trials of an evaluation: :data:`~envs.harness.workers.TASKS`);
each time it gets the map as the learner has it. An actor that dies (killed, out of memory, its
node lost) takes the round with it: new actors are started and the round redone, as the local
workers are. Ray is imported when a pool is made (the extra ``sweep``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from envs.harness.ray_cluster import (
    AddressError,
    RayUnavailableError,
    check_address,
    check_reachable,
    need_ray,
    start_ray,
)
from envs.harness.workers import POLL_SECONDS, TASKS, RoundPool, Share, WorkerDied
from learners.persistence import quoted

#: What needs Ray, in the error when it is missing or its cluster cannot be reached.
WHAT = "--address (the workers as Ray actors)"


class Collector:
    """A Ray actor's state: the run's configuration, and its env once the first share needs it."""

    def __init__(self, config: Any) -> None:
        self.config = config
        self.env: Any = None

    def run(self, task: str, blob: bytes, seed: int, indices: range, moves: int) -> Share:
        """``task`` of :data:`~envs.harness.workers.TASKS` in this actor's env."""
        if self.env is None:
            import envs  # noqa: F401  (registers the envs in this process)

            self.env = self.config.make_env()
        return TASKS[task](self.env, blob, seed, indices, moves)


class RayPool(RoundPool):
    """N Ray actors that run a round's trials, one CPU each, on the Ray cluster at ``address``
    (:func:`~envs.harness.ray_cluster.check_address`: ``auto``, ``HOST:PORT``, or ``local``
    for a new local instance of N CPUs). Ray already initialised in this process is used as it
    is; Ray started here is shut down by :meth:`close`.

    Raises:
        AddressError: ``address`` is not a Ray address.
        RayUnavailableError: Ray is not installed, or no head answers at ``address``.
    """

    errors_shown = "see the Ray workers' logs (/tmp/ray/session_latest/logs)"

    def __init__(self, config: Any, workers: int, address: str) -> None:
        check_address(address)
        super().__init__(config, workers)
        self._ray = ray = need_ray(WHAT)
        self._started = not ray.is_initialized()
        if self._started:
            try:
                start_ray(address, num_cpus=workers)
            except ConnectionError as exc:
                raise RayUnavailableError(f"{WHAT}: {quoted(exc)}") from None
        self._actor = ray.remote(num_cpus=1, max_restarts=0)(Collector)
        self._actors = self._start()

    def _start(self) -> list[Any]:
        return [self._actor.remote(self.config) for _ in range(self.workers)]

    def _run(
        self, task: str, blob: bytes, parts: list[range], moves: int, check: Callable[[], None]
    ) -> list[Share]:
        ray = self._ray
        shared = ray.put(blob)  # one copy in Ray's object store for all actors
        refs = [
            actor.run.remote(task, shared, self.config.seed, part, moves)
            for actor, part in zip(self._actors, parts, strict=False)
        ]
        try:
            pending = refs
            while pending:
                ready, pending = ray.wait(pending, num_returns=len(pending), timeout=POLL_SECONDS)
                check()
                ray.get(ready)  # an actor's death (or its share's error) raised now
            return list(ray.get(refs))
        except (ray.exceptions.RayActorError, ray.exceptions.ActorUnavailableError) as exc:
            raise WorkerDied(str(exc)) from None

    def _restart(self) -> None:
        self._kill()
        self._actors = self._start()

    def _kill(self) -> None:
        for actor in self._actors:
            self._ray.kill(actor)

    def close(self) -> None:
        self._kill()
        if self._started:
            self._ray.shutdown()


def ray_pools(address: str, workers: int) -> Callable[[Any, int], RayPool]:
    """The pools of a run of ``workers`` workers as Ray actors at ``address`` (what
    ``Trainer.make_pool`` takes), checked before any work: AddressError if ``address`` is not a
    Ray address or ``workers`` < 2 (one worker is the one-process training), RayUnavailableError
    if no head answers at it or Ray is not installed."""
    check_address(address)
    if workers < 2:
        raise AddressError(
            f"address {address!r} runs the workers as Ray actors, but the run has {workers} "
            "worker; take 2 or more workers, or leave out the address"
        )
    check_reachable(address)
    need_ray(WHAT)
    return functools.partial(RayPool, address=address)
