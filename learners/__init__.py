"""Controllers that map camera coordinates to joint commands (numpy only, no MuJoCo)."""

from learners.base import Controller, Learner, PathFollower
from learners.baselines.analytic_ik import AnalyticIK
from learners.baselines.jacobian_ik import JacobianIK
from learners.baselines.random_controller import RandomController
from learners.natenet import NATEnet, PathTracker
from learners.persistence import CheckpointError
from learners.som.controller import VisuomotorSOM

__all__ = [
    "AnalyticIK",
    "CheckpointError",
    "Controller",
    "JacobianIK",
    "Learner",
    "NATEnet",
    "PathFollower",
    "PathTracker",
    "RandomController",
    "VisuomotorSOM",
]
