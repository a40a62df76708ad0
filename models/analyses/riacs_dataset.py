"""The RIACS data set of Jorgensen (1990): ``build3dpts`` and ``buildtset`` of the report's
appendix.

``build3dpts(arm1, arm2, stepsize)`` steps the three joints over their ranges (MATLAB colon
ranges ``.001:stepsize:end``), computes the tool point with ``robot3df`` and its two camera images
with ``camera(focallength=1, separation=.3)``, one row per joint triple:
``x y z x1 y1 x2 y2 theta1 theta2 theta3``. The report steps the base joint "in three degree
increments", so the default step is π/60. The extracted MATLAB line of the second loop is garbled
(``.001:stepsize:.001:stepsize:(pi/2 - asin(arm2/arm1))``); it is read as
``.001:stepsize:(pi/2 - asin(arm2/arm1))``, the range its comment states.

``buildtset(data, numpoints)`` draws rows uniformly *with replacement* (``data(ceil(rand*a),:)``);
:func:`train_test_split` offers that (train and test drawn independently, so they may share rows)
and a split without replacement (disjoint).
"""

from __future__ import annotations

import numpy as np

from models.riacs.kinematics import FOCAL_LENGTH, HALF_SEPARATION, LINK1, LINK2, camera, robot3df

COLUMNS = ("x", "y", "z", "x1", "y1", "x2", "y2", "theta1", "theta2", "theta3")
STEP = np.pi / 60  #: rad, 3°: "the base joint was stepped ... in three degree increments"
JOINT_START = 0.001  #: rad, first value of every joint loop
#: MATLAB's colon operator tolerates this relative rounding in (stop - start) / step.
_COLON_TOLERANCE = 1e-10


def colon(start: float, step: float, stop: float) -> np.ndarray:
    """MATLAB ``start:step:stop`` for step > 0: start + k·step while ≤ stop."""
    if not step > 0:
        raise ValueError(f"stepsize must be > 0 rad, got {step!r}")
    count = int(np.floor((stop - start) / step + _COLON_TOLERANCE)) + 1
    return start + step * np.arange(max(count, 0))


def joint_ranges(arm1: float, arm2: float, stepsize: float) -> tuple[np.ndarray, ...]:
    """The three loop ranges of build3dpts (rad)."""
    return (
        colon(JOINT_START, stepsize, np.pi / 2),
        colon(JOINT_START, stepsize, np.pi / 2 - np.arcsin(arm2 / arm1)),
        colon(JOINT_START, stepsize, np.pi - np.pi / 180),
    )


def build3dpts(arm1: float = LINK1, arm2: float = LINK2, stepsize: float = STEP) -> np.ndarray:
    """All reachable grid points with their camera images and joint angles.

    Args:
        arm1, arm2: link lengths (m); stepsize: joint step (rad).
    Returns:
        (N, 10) rows in :data:`COLUMNS` order, loops nested as in the MATLAB (θ1 outermost).
    """
    t1, t2, t3 = np.meshgrid(*joint_ranges(arm1, arm2, stepsize), indexing="ij")
    t1, t2, t3 = t1.ravel(), t2.ravel(), t3.ravel()
    x, y, z = robot3df(arm1, arm2, t1, t2, t3)
    x1, y1, x2, y2 = camera(FOCAL_LENGTH, HALF_SEPARATION, x, y, z)
    return np.stack([x, y, z, x1, y1, x2, y2, t1, t2, t3], axis=-1)


def buildtset(data: np.ndarray, numpoints: int, rng: np.random.Generator) -> np.ndarray:
    """``numpoints`` rows of ``data`` drawn uniformly with replacement (the report's buildtset)."""
    return data[rng.integers(0, len(data), size=numpoints)]


def train_test_split(
    data: np.ndarray, n_train: int, n_test: int, rng: np.random.Generator, replace: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """A seeded train and test set.

    Args:
        replace: True: two independent ``buildtset`` draws (the report's way; rows may repeat and
            appear in both); False: disjoint sets from one permutation (needs n_train + n_test ≤ N).
    Returns:
        (train (n_train, 10), test (n_test, 10)).
    """
    if replace:
        return buildtset(data, n_train, rng), buildtset(data, n_test, rng)
    if n_train + n_test > len(data):
        raise ValueError(
            f"n_train + n_test = {n_train + n_test} exceeds the {len(data)} rows; lower them or "
            "sample with replacement"
        )
    order = rng.permutation(len(data))
    return data[order[:n_train]], data[order[n_train : n_train + n_test]]
