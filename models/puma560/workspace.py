"""Where the PUMA stands in the world and where its reach targets are drawn."""

import numpy as np

from models.workspace import BoxWorkspace

#: World position of DH frame 0 (site ``base``): the shoulder, 0.6718 m above the floor.
BASE_POS = np.array([0.0, 0.0, 0.6718])

#: Wrist-centre target box relative to frame 0 (m): 0.5 × 0.4 × 0.6, every point reachable in the
#: right-above configuration with joints 1-3 in range, ≥ 3 cm inside the reach sphere and ≥ 0.2 m
#: from the joint-1 axis (see README.md).
WORKSPACE_BASE_LOWER = np.array([-0.25, 0.35, -0.30])
WORKSPACE_BASE_UPPER = np.array([0.25, 0.75, 0.30])
WORKSPACE = BoxWorkspace(BASE_POS + WORKSPACE_BASE_LOWER, BASE_POS + WORKSPACE_BASE_UPPER)
