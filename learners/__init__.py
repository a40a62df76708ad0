"""Controllers that map camera coordinates to joint commands (numpy only, no MuJoCo)."""

from learners.analytic_ik import AnalyticIK
from learners.base import Controller
from learners.jacobian_ik import JacobianIK
from learners.natenet import NATEnet, PathTracker
from learners.persistence import CheckpointError
from learners.random_controller import RandomController
from learners.som import VisuomotorSOM

__all__ = [
    "AnalyticIK",
    "CheckpointError",
    "Controller",
    "JacobianIK",
    "NATEnet",
    "PathTracker",
    "RandomController",
    "VisuomotorSOM",
]
