"""A step's ``info`` as a dict that goal-relabelling replay buffers copy quickly."""

from __future__ import annotations

from copy import deepcopy
from typing import Any

import numpy as np

#: Types whose values are copied as they are (immutable).
IMMUTABLE = frozenset({float, int, bool, str, type(None), np.bool_, np.float64, np.int64})


class StepInfo(dict):
    """The ``info`` of a reset or step: a plain dict (every dict operation and pickling as
    usual) whose deep copy is several times quicker than ``copy.deepcopy`` of a dict.

    Stable-Baselines3's ``HerReplayBuffer`` with ``copy_info_dict=True`` (what
    ``compute_reward`` needs: ``info["visible_effector"]``) deep-copies the info of every
    relabelled transition it samples, each gradient step; ``copy.deepcopy`` dispatches every
    entry through Python. Here numbers and strings are kept (immutable), numeric arrays copied
    with ``ndarray.copy`` and anything else (what wrappers add, such as SB3's
    ``terminal_observation``) deep-copied as usual: the copy is as deep, only quicker.
    """

    __slots__ = ()

    def __deepcopy__(self, memo: dict[int, Any]) -> StepInfo:
        copied = StepInfo(self)  # immutable values are done
        memo[id(self)] = copied
        for key, value in self.items():
            kind = type(value)
            if kind is np.ndarray and value.dtype != object:
                copied[key] = value.copy(order="K")
            elif kind not in IMMUTABLE:
                copied[key] = deepcopy(value, memo)
        return copied
