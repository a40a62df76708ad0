"""Rendered sensing against the exact projection, by how much of the marker the robot hides.

For random in-range poses with the marker's centre inside both images, the effector marker is
sensed from whole images and foveated (windows about a prediction a few pixels off, as after a
reach), and compared with the projection of the sensed site. The hidden fraction of each camera's
view is 1 - (marker pixels with the robot drawn) / (marker pixels without it), holes (the
specular highlight) filled.
"""

from __future__ import annotations

import itertools

import gymnasium as gym
import numpy as np

from envs.sensing.foveated import FoveatedSensing
from envs.sensing.marker_detection import GREEN_EFFECTOR, find_blob
from envs.sensing.rendering import GROUP_MARKER, GROUP_ROBOT, GROUP_SCENE

#: Edges of the hidden-fraction bins in the table.
HIDDEN_BINS = (0.0, 0.01, 0.25, 0.5, 0.7, 1.0)
#: Standard deviation (px) of the prediction the foveated windows are placed about.
PREDICTION_PX = 2.0
#: The marker centre's projection stays this far (px) inside the images.
INSIDE_PX = 3.0


def measure(env: gym.Env, poses: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Per pose and camera (poses, 2): hidden fraction, and the px error of whole-image and of
    foveated sensing (NaN where not reported visible)."""
    base = env.unwrapped
    st, radius = base.stereo, base.marker_radius
    fovea = FoveatedSensing(st)
    out = {name: np.full((poses, 2), np.nan) for name in ("hidden", "whole", "foveated")}
    i = 0
    while i < poses:
        base.set_joints(rng.uniform(base.joint_lower, base.joint_upper))
        projected = st.project(base.sensed_point()[None])[0]  # (4,)
        u, v = projected[::2], projected[1::2]
        if not (np.all((u > INSIDE_PX) & (u < st.width - 1 - INSIDE_PX))
                and np.all((v > INSIDE_PX) & (v < st.height - 1 - INSIDE_PX))):  # fmt: skip
            continue
        counts = []
        for groups in ((GROUP_SCENE, GROUP_MARKER), (GROUP_SCENE, GROUP_ROBOT, GROUP_MARKER)):
            views = st.render_views(base.data, groups)
            blobs = [find_blob(rgb, GREEN_EFFECTOR, whole=True) for rgb, _ in views]
            counts.append([0 if b is None else b.count for b in blobs])
        alone, seen = np.array(counts, dtype=float)
        out["hidden"][i] = 1.0 - seen / np.maximum(alone, 1.0)
        guess = projected + rng.normal(0.0, PREDICTION_PX, 4)
        for name, (pixels, _) in (
            ("whole", st.sense(base.data, GREEN_EFFECTOR, radius)),
            ("foveated", fovea.sense(base.data, GREEN_EFFECTOR, radius, guess)),
        ):
            out[name][i] = np.hypot(*(pixels - projected).reshape(2, 2).T)
        i += 1
    return out


def table(result: dict[str, np.ndarray]) -> list[dict[str, float]]:
    """Rows per hidden-fraction bin (over cameras): count, share reported visible, mean and max
    px error, for whole-image and foveated sensing."""
    hidden = result["hidden"].ravel()
    rows = []
    for lo, hi in itertools.pairwise(HIDDEN_BINS):
        inside = (hidden >= lo) & ((hidden < hi) if hi < 1.0 else (hidden <= hi))
        row: dict[str, float] = {"hidden_from": lo, "hidden_to": hi, "views": int(inside.sum())}
        for name in ("whole", "foveated"):
            e = result[name].ravel()[inside]
            ok = e[np.isfinite(e)]
            row[f"{name}_visible"] = float(len(ok) / max(len(e), 1))
            row[f"{name}_mean_px"] = float(ok.mean()) if len(ok) else float("nan")
            row[f"{name}_max_px"] = float(ok.max()) if len(ok) else float("nan")
        rows.append(row)
    return rows
