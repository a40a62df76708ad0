"""Helpers shared by the test modules: one copy of each.

- :func:`hand_set_map`: a small Kohonen map with hand-set arrays, whose answers can be computed
  by hand.
- :func:`riacs_pixels`: the RIACS report's stereo cameras in pure numpy, an independent stand-in
  for the rendered cameras.
- :data:`SCRIPTS`, :func:`run_script` and :func:`one_line_error`: the command-line programs of the
  checkout run in a child process, and the one-line user error they must print.
- :func:`forbid_the_exact_model`: kinematics, IK and the camera model raise if touched, for the
  tests that a learner (training, recovery) uses only what a robot knows.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from learners.som.controller import VisuomotorSOM
from models import riacs

#: The checkout's command-line wrappers (``scripts/<name>.py``).
SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
#: Lattice points of the (3, 2) lattice of :func:`hand_set_map`, in C order.
SMALL_LATTICE = (3, 2)
SMALL_COORDS = [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1)]
#: The RIACS report's camera (focal length 1, half baseline 0.3) scaled to an image of 320 px:
#: 200 px per normalised unit about the image centre at 160 px.
RIACS_PX_PER_UNIT = 200.0
RIACS_CENTRE_PX = 160.0


def hand_set_map(low: np.ndarray, high: np.ndarray, **kw) -> VisuomotorSOM:
    """A map on the (3, 2) lattice with 2-D input and 2 joints in [low, high], with hand-set
    arrays: w_r at the lattice point r, θ_r = (0.1 k, −0.2 k) and A_r = [[1 + k, 0.5],
    [0, 2 − 0.3 k]] for neuron k (C order). ``kw`` goes to the constructor."""
    som = VisuomotorSOM(low, high, lattice=SMALL_LATTICE, input_dim=2, rng=0, **kw)
    som.w = np.array(SMALL_COORDS, dtype=float)
    som.theta = np.array([[0.1 * k, -0.2 * k] for k in range(len(SMALL_COORDS))])
    som.A = np.array([[[1.0 + k, 0.5], [0.0, 2.0 - 0.3 * k]] for k in range(len(SMALL_COORDS))])
    return som


def riacs_pixels(theta: np.ndarray, shift: float = 0.0) -> np.ndarray:
    """Pixels (4,) of the RIACS arm's effector at joint angles ``theta`` (3,) seen by the report's
    cameras (f = 1, d = 0.3) at 200 px per unit, both images moved by ``shift`` px (the cameras
    moved): pure numpy, no MuJoCo."""
    point = riacs.robot3df(riacs.LINK1, riacs.LINK2, *theta)
    return RIACS_CENTRE_PX + shift + RIACS_PX_PER_UNIT * np.array(riacs.camera(1.0, 0.3, *point))


def run_script(name: str, *args: str, **kw) -> subprocess.CompletedProcess:
    """Run ``scripts/<name>.py`` with ``args`` in a child process; ``kw`` goes to subprocess."""
    command = [sys.executable, str(SCRIPTS / f"{name}.py"), *args]
    return subprocess.run(command, capture_output=True, text=True, check=False, **kw)


def one_line_error(result: subprocess.CompletedProcess) -> str:
    """The user error a program printed: exit status 2, no traceback and exactly one line that
    says ``error:`` (argparse's usage may precede it). Returns that line."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    lines = [line for line in result.stderr.splitlines() if "error:" in line]
    assert len(lines) == 1, result.stderr
    return lines[0]


def assert_drawn_png(path: Path) -> None:
    """The file at ``path`` decodes as a PNG image with something drawn on it (more than one
    colour). What the figure shows is tested on the Figure itself (tests/test_figures.py)."""
    import matplotlib.image

    image = matplotlib.image.imread(path)  # (height, width, channels) floats in [0, 1]
    assert image.ndim == 3 and min(image.shape[:2]) > 100, image.shape
    colours = np.unique(image.reshape(-1, image.shape[2]), axis=0)
    assert len(colours) > 2, f"{path} is blank"


def forbid_the_exact_model(monkeypatch) -> None:
    """Make the kinematics, the IKs and the stereo rig's camera model raise AssertionError if
    anything calls them (``monkeypatch`` undoes it after the test). Sensing renders the scene
    and does not use them."""
    import models.arms
    import models.puma560
    import models.puma560.inverse
    import models.puma560.kinematics
    import models.riacs.kinematics
    from envs.sensing.stereo import StereoRig

    def forbidden(*args, **kwargs):
        raise AssertionError("the learner used the exact model")

    for module, name in [(models.arms, "arm_kinematics"), (models.puma560, "wrist_ik"),
                         (models.puma560.kinematics, "wrist_ik"),
                         (models.puma560.kinematics, "wrist_center"),
                         (models.puma560.inverse, "pose_ik"),
                         (models.riacs.kinematics, "robot3dinv"),
                         (models.riacs.kinematics, "robot3df"),
                         (StereoRig, "project"), (StereoRig, "project_with_depth")]:  # fmt: skip
        monkeypatch.setattr(module, name, forbidden)
