"""Films of the grasp task: the PUMA's hand brought onto objects.

:class:`GraspFilm` films any controller's trials (``scripts/video.py --env PumaGrasp-v0``, and
the documentation's animation ``docs/assets/PumaGrasp-v0.gif`` of a trained map,
``scripts/docs_media.py``) through the env's ``on_physics_step`` hook. Filming only reads the
simulation, so a filmed move gives the same numbers as one that is not.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from envs.harness.trials import Trial, run_trial
from envs.harness.video import annotate

HOLD_SECONDS = 0.7  # s of video that the new target and each move's result stay on screen


class GraspFilm:
    """Films trials of a controller on a grasp env, with the interface of
    :class:`envs.harness.film.TrialFilm` (so :func:`~envs.harness.film.side_by_side` stacks
    two of them): the env's own three views (``render_mode="rgb_array"``: the object's markers
    crosshaired, the hand's detected markers circled), a frame every ``speed / fps`` s of a
    servo move, and after each move a held frame with the position and orientation errors. A
    kinematic move sets the joints, so it shows as its result only.

    Args:
        env: a :class:`~envs.grasp.GraspEnv` (or a wrapper of one) made with
            ``render_mode="rgb_array"``.
        title: the first overlay line of every frame.
        fps: frames per second of the video; speed: simulated seconds per second of video.
        panel: (width, height) of each of the three views.
        text_scale: OpenCV font scale of the overlay (default: in proportion to the height).
    """

    def __init__(
        self,
        env,
        title: str,
        fps: float,
        speed: float = 1.0,
        panel: tuple[int, int] = (600, 450),
        text_scale: float | None = None,
    ) -> None:
        self.env, self.base, self.title = env, env.unwrapped, title
        self.fps, self.speed, self.size = fps, speed, (3 * panel[0], panel[1])
        self.text_scale = panel[1] / 600 if text_scale is None else text_scale

    def _grab(self, lines: list[str]) -> np.ndarray:
        frame = cv2.resize(self.env.render(), self.size, interpolation=cv2.INTER_AREA)
        return annotate(frame, [self.title, *lines], scale=self.text_scale)

    def trial(self, controller, fine_moves: int, label: str) -> tuple[Trial, list[list]]:
        """Run one trial (:func:`~envs.harness.trials.run_trial`) and film it; returns the
        trial and its frames: the new object, then one list per move made."""
        hold = max(1, round(HOLD_SECONDS * self.fps))
        stages: list[list[np.ndarray]] = []
        moving: list[np.ndarray] = []
        due = {"next": 0.0, "k": 0}

        def on_step(elapsed: float) -> None:
            if elapsed + 1e-12 >= due["next"]:
                due["next"] += self.speed / self.fps
                stage = "coarse move" if due["k"] == 0 else f"fine move {due['k']}"
                moving.append(self._grab([f"{label}   {stage}   moving, t = {elapsed:.2f} s"]))

        def on_move(k: int, trial: Trial) -> None:
            if k < 0:
                stages.append([self._grab([f"{label}   new object"])] * hold)
                return
            stage = "coarse move" if k == 0 else f"fine move {k}"
            error = (
                f"{1e3 * trial.distances[k]:.1f} mm, "
                f"{math.degrees(trial.orientation_errors[k]):.2f} deg"
            )
            seen = "" if trial.visible[k] else "   a marker not seen"
            end = self._grab([f"{label}   {stage}   error {error}{seen}"])
            stages.append([*moving, *[end] * hold])
            moving.clear()
            due.update(next=0.0, k=k + 1)

        self.base.on_physics_step = on_step if self.base.control == "servo" else None
        try:
            trial = run_trial(self.env, controller, fine_moves, on_move=on_move)
        finally:
            self.base.on_physics_step = None
        return trial, stages

    def close(self) -> None:
        """Nothing to release: the env renders (and is closed by its owner)."""
