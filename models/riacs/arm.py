"""The RIACS arm's kinematics for the exact controllers (:class:`models.arms.ArmKinematics`) and
its parameter chain for the accuracy analysis: the tool point (site ``tcp``), forward
``robot3df``, inverse the report's ``robot3dinv``, Jacobian from
:data:`models.chain.RIACS_CHAIN`."""

from __future__ import annotations

import numpy as np

from models.arms import ArmKinematics, pull_to_shell
from models.chain import RIACS_CHAIN, RIACS_JOINTS, RobotChain, riacs_parameters
from models.joints import wrap_into_range
from models.riacs.kinematics import HOME, LINK1, LINK2, LOWER, UPPER, robot3df, robot3dinv


def tool(configuration: str = "right-above") -> ArmKinematics:
    """The tool point (site ``tcp``), ``robot3df`` / ``robot3dinv``; the report's arm has one
    branch, so ``configuration`` (a PUMA option) is ignored."""
    l1, l2 = LINK1, LINK2

    def forward(theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        return np.stack(robot3df(l1, l2, theta[..., 0], theta[..., 1], theta[..., 2]), -1)

    def jac(theta: np.ndarray) -> np.ndarray:
        return RIACS_CHAIN.position_jacobian(riacs_parameters(theta, l1, l2), RIACS_JOINTS)

    def inverse(points: np.ndarray, reference: np.ndarray | None = None):
        p = np.atleast_2d(np.asarray(points, dtype=float))
        pulled = pull_to_shell(p, abs(l1 - l2), l1 + l2)
        theta = np.stack(robot3dinv(l1, l2, *pulled.T), axis=-1)
        theta, in_range = wrap_into_range(theta, LOWER, UPPER, reference)
        return theta, np.all(pulled == p, axis=-1) & in_range

    home = HOME.copy()  # mid-range: well conditioned
    return ArmKinematics(
        "riacs", LOWER.copy(), UPPER.copy(), home, home.copy(), forward, jac, inverse
    )


def accuracy_chain() -> RobotChain:
    """θ1-θ3, link1, link2 from site ``base`` to site ``tcp``: bodies ``link1``, ``link2`` and
    site ``tcp`` hold the fixed factors after each joint."""
    segments = (("body", "link1"), ("body", "link2"), ("site", "tcp"))
    return RobotChain(
        "riacs",
        RIACS_CHAIN,
        tuple(RIACS_JOINTS),
        segments,
        lambda theta: riacs_parameters(theta, LINK1, LINK2),
    )
