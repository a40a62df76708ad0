"""The reach reward: one function for the step and for relabelled goals (HER).

``reward = reward_distance + reward_unseen`` where ``reward_distance`` is minus the distance (m)
between the triangulated achieved and desired goals, and ``reward_unseen`` is minus the robot's
reach (m) when the effector marker was not seen after the move (its achieved goal is then the
last valid sighting, not where the arm is), else 0. Whether the marker was seen travels in
``info["visible_effector"]``, so a relabelled transition keeps the penalty that belongs to its
achieved goal. The target's visibility does not enter: the reward is relative to the desired goal
as observed, which relabelling replaces.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from envs.sensing.triangulation import CameraFloats, distance_elementwise, triangulate_elementwise

#: ``info`` key saying whether both cameras saw the effector marker after the move.
SEEN_KEY = "visible_effector"
#: Single-transition triangulations remembered (the desired goal repeats within an episode).
CACHE_SIZE = 64


class GoalPoints:
    """The stereo rig's cameras as floats, and the triangulations of single goals already
    computed with them (a remembered point has the same bits as a recomputed one)."""

    def __init__(self, cameras: tuple[CameraFloats, ...]) -> None:
        self.cameras = cameras
        self._memo: dict[tuple[float, ...], tuple[float, ...]] = {}

    def point(self, q: tuple[float, ...]) -> tuple[float, ...]:
        p = self._memo.get(q)
        if p is None:
            if len(self._memo) >= CACHE_SIZE:
                self._memo.clear()
            p = self._memo[q] = triangulate_elementwise(self.cameras, q)
        return p


def _seen(info: Mapping[str, Any]) -> bool:
    try:
        seen = info[SEEN_KEY]
        return all(seen.tolist()) if isinstance(seen, np.ndarray) else bool(np.all(seen))
    except KeyError:
        raise KeyError(
            f"info has no {SEEN_KEY!r}: pass the info dict(s) the env returned with these goals "
            "(Stable-Baselines3: HerReplayBuffer with replay_buffer_kwargs={'copy_info_dict': "
            "True}), or None to treat every effector marker as seen"
        ) from None


def seen_flags(info: Any, shape: tuple[int, ...]) -> bool | np.ndarray:
    """Whether the effector was seen, from ``info`` as HER passes it: a dict (one transition, or
    one for the whole batch), a sequence or object array of dicts shaped like the batch, or None
    (every marker seen). A bool for ``shape == ()``, else a bool array of ``shape``."""
    if info is None:
        return True if shape == () else np.ones(shape, dtype=bool)
    if isinstance(info, Mapping):
        seen = _seen(info)
        return seen if shape == () else np.full(shape, seen)
    items = np.asarray(info, dtype=object)  # dicts are not sequences: one item per dict
    flags = np.vectorize(_seen, otypes=[bool])(items) if items.size else np.ones(items.shape, bool)
    try:
        flags = np.broadcast_to(flags, shape)
    except ValueError:
        raise ValueError(
            f"info holds {flags.shape} dicts but the goals are a batch of shape {shape}; pass one "
            "info dict per transition (as HER does), one dict, or None"
        ) from None
    return bool(flags) if shape == () else flags


def reward_terms(
    goals: GoalPoints,
    achieved: Sequence[Any],
    desired: Sequence[Any],
    seen: bool | np.ndarray,
    penalty: float,
) -> tuple[Any, Any]:
    """(reward_distance, reward_unseen) in metres, elementwise.

    Args:
        goals: the stereo rig's two cameras (and remembered single points).
        achieved, desired: four pixel coordinates each, Python floats for one transition or
            arrays of the batch shape.
        seen: effector marker seen, bool or bool array of the batch shape.
        penalty: what an unseen marker costs, metres (> 0).
    """
    if isinstance(seen, bool):  # one transition, Python floats
        distance = distance_elementwise(goals.point(tuple(achieved)), goals.point(tuple(desired)))
        return -distance, 0.0 if seen else -float(penalty)
    distance = distance_elementwise(
        triangulate_elementwise(goals.cameras, achieved),
        triangulate_elementwise(goals.cameras, desired),
    )
    return -distance, np.where(seen, 0.0, -penalty)
