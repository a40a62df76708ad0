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

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from envs.sensing import pinhole_kernels
from envs.sensing.triangulation import CameraFloats, distance_elementwise, triangulate_elementwise

#: ``info`` key saying whether both cameras saw the effector marker after the move.
SEEN_KEY = "visible_effector"


class GoalPoints(NamedTuple):
    """The stereo rig's cameras for triangulating goals: as floats (the numpy path) and as rows
    (2, 16) of :func:`envs.sensing.triangulation.camera_array` (the compiled one)."""

    cameras: tuple[CameraFloats, ...]
    rows: np.ndarray


def goal_distances(goals: GoalPoints, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
    """Distances (N,) m between the triangulated points of the goals ``achieved`` and
    ``desired`` (4, N) px: the compiled kernel when numba is installed, else the same
    operations on arrays (the same bits)."""
    if pinhole_kernels.ENABLED:
        out = np.empty(achieved.shape[1])
        pinhole_kernels.goal_distances(goals.rows, achieved, desired, out)
        return out
    return distance_elementwise(
        triangulate_elementwise(goals.cameras, achieved),
        triangulate_elementwise(goals.cameras, desired),
    )


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
    if isinstance(info, dict) or isinstance(info, Mapping):  # dict first: the ABC test is slow
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
    achieved: np.ndarray,
    desired: np.ndarray,
    seen: bool | np.ndarray,
    penalty: float,
) -> tuple[Any, Any]:
    """(reward_distance, reward_unseen) in metres, elementwise.

    Args:
        goals: the stereo rig's two cameras.
        achieved, desired: goals (4, *shape) px of one batch shape (``()`` for one transition).
        seen: effector marker seen, bool for one transition or a bool array of the batch shape.
        penalty: what an unseen marker costs, metres (> 0).
    Returns:
        floats for one transition, arrays of the batch shape otherwise.
    """
    shape = achieved.shape[1:]
    distance = goal_distances(goals, achieved.reshape(4, -1), desired.reshape(4, -1))
    if isinstance(seen, bool):  # one transition
        return -float(distance[0]), 0.0 if seen else -float(penalty)
    return -distance.reshape(shape), np.where(seen, 0.0, -penalty)


def total_reward(terms: tuple[Any, ...]) -> Any:
    """The reward: its terms added in order (floats, or arrays of one batch shape)."""
    total = terms[0]
    for term in terms[1:]:
        total = total + term
    return total
