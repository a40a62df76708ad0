"""Gymnasium environments and stereo camera sensing.

Importing this package chooses the off-screen GL back-end (before mujoco is imported) and
registers the environments with Gymnasium.
"""

from envs.rendering import configure_gl_backend

configure_gl_backend()

from envs.stereo import StereoRig  # noqa: E402

__all__ = ["StereoRig"]
