"""Where every random target comes from: one seed, several streams that never meet.

A run's seed s names a family of generators, one per purpose, told apart by the spawn key of a
``numpy.random.SeedSequence`` (the generator is ``PCG64(SeedSequence(s, spawn_key=key))``):

| stream | spawn key | draws |
|---|---|---|
| ``training`` | () | the training targets: exactly what ``env.reset(seed=s)`` draws |
| ``evaluation`` | (1,) | held-out targets (``evaluate.py --seed``, held-out rows, videos) |
| ``validation`` | (2,) | targets on which a setting is chosen by measurement |
| workers' trials | (3, k, 0), (3, k, 1) | trial k's target and moves with ``--workers`` ≥ 2 |

A SeedSequence hashes its entropy together with its spawn key, so the streams of different
keys share no state for any pair of seeds (``tests/test_streams.py`` draws the sets and checks).
The workers' keys are ``envs.harness.workers.trial_rngs``'s.
Training keeps the empty key so that runs trained before the streams existed resume unchanged.
"""

from __future__ import annotations

import numpy as np

#: The spawn key of each stream.
SPAWN_KEYS: dict[str, tuple[int, ...]] = {"training": (), "evaluation": (1,), "validation": (2,)}
STREAMS = tuple(SPAWN_KEYS)


def sequence(seed: int, stream: str) -> np.random.SeedSequence:
    """The SeedSequence of ``stream`` under ``seed`` (a non-negative integer)."""
    if stream not in SPAWN_KEYS:
        raise ValueError(f"unknown stream {stream!r}; valid: {', '.join(STREAMS)}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed is {seed!r}; it takes an integer >= 0")
    return np.random.SeedSequence(int(seed), spawn_key=SPAWN_KEYS[stream])


def generator(seed: int, stream: str) -> np.random.Generator:
    """A fresh generator of ``stream`` under ``seed``."""
    return np.random.Generator(np.random.PCG64(sequence(seed, stream)))


def seed_env(env, seed: int, stream: str) -> None:
    """Make ``env`` (a Gymnasium env or wrapper) draw its next targets from ``stream`` under
    ``seed``: its ``np_random`` is replaced, so the next ``reset()`` (without a seed) draws the
    stream's first target."""
    env.unwrapped.np_random = generator(seed, stream)
