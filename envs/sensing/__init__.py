"""Camera sensing: off-screen rendering, the stereo rig, marker detection and fit, foveated windows.

Layering: imports nothing from the rest of ``envs``; the environments build on it.
"""
