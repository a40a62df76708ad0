"""The visuomotor Kohonen map (Ritter, Martinetz & Schulten; Brause): the controller, its
compiled path and kernels, the winner search, the lattice, the local fit of Ā and the schedules."""

from learners.som.config import SOMConfig
from learners.som.controller import VisuomotorSOM

__all__ = ["SOMConfig", "VisuomotorSOM"]
