"""A film of the pose task: the PUMA's hand brought onto objects by the exact pose IK.

For the documentation's animation of ``PumaGrasp-v0`` (``docs/assets/PumaGrasp-v0.gif``): each
trial draws an object, holds the new target, then films one servo move onto the joints of the
exact pose IK (:attr:`envs.grasp.GraspEnv.target_joints`, the floor a learner is measured
against) through the env's ``on_physics_step`` hook, a frame every ``1 / fps`` s of simulated
time, and holds the result with the position and orientation errors. Filming only reads the
simulation, so a filmed move gives the same numbers as one that is not.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from envs.grasp import GraspEnv
from envs.harness.video import annotate

HOLD_SECONDS = 0.7  # s of video that the new target and each move's result stay on screen


def grasp_frames(
    trials: int, seed: int, fps: float, panel: tuple[int, int] = (256, 192)
) -> list[np.ndarray]:
    """RGB frames of ``trials`` exact-IK grasps (servo control, foveated sensing), each of the
    three views of ``env.render()`` scaled to ``panel`` (width, height) pixels."""
    env = GraspEnv(sensing="foveated", control="servo", render_mode="rgb_array")
    size = (3 * panel[0], panel[1])
    frames: list[np.ndarray] = []

    def grab(lines: list[str]) -> np.ndarray:
        frame = cv2.resize(env.render(), size, interpolation=cv2.INTER_AREA)
        return annotate(frame, lines)

    hold = max(1, round(HOLD_SECONDS * fps))
    moving = {"title": "", "due": 0.0}  # the trial's title, the next frame's time (s)

    def on_step(elapsed: float) -> None:
        if elapsed >= moving["due"]:
            frames.append(grab([moving["title"], "moving"]))
            moving["due"] += 1.0 / fps

    for trial in range(trials):
        env.reset(seed=seed + trial)
        title = f"PumaGrasp-v0  exact pose IK  trial {trial + 1}/{trials}"
        frames.extend([grab([title, "new object"])] * hold)
        moving.update(title=title, due=0.0)
        env.on_physics_step = on_step
        _, _, _, _, info = env.step(env.target_joints)
        env.on_physics_step = None
        error = (
            f"{1e3 * info['distance']:.1f} mm, {math.degrees(info['orientation_error']):.2f} deg"
        )
        frames.extend([grab([title, f"grasped: {error}"])] * hold)
    env.close()
    return frames
