"""Controllers that map camera coordinates to joint commands (numpy only, no MuJoCo)."""

from learners.base import Controller
from learners.persistence import CheckpointError

__all__ = ["CheckpointError", "Controller"]
