"""Shared test setup: a headless GL back-end chosen before anything imports mujoco.

MuJoCo reads ``MUJOCO_GL`` once, when it is imported, and pytest imports this file before any test
module. EGL is the default (Mesa's llvmpipe renders without a GPU or display); a back-end the
caller chose (``MUJOCO_GL=osmesa make test``) is kept.
"""

import os

DEFAULT_GL_BACKEND = "egl"

os.environ.setdefault("MUJOCO_GL", DEFAULT_GL_BACKEND)
