"""Films of reach trials: frames at a video's rate of the arm moving, with the sensing drawn.

A servo move is filmed while the simulation settles: the env's ``on_physics_step`` hook hands
every physics step to :class:`TrialFilm`, which draws a frame each time ``speed / fps`` seconds
of simulated time have passed (real time at ``speed=1``). Drawing only reads the simulation, so
a filmed trial gives the same numbers as one that is not filmed. A kinematic move has no motion
to film (the joints are set): it is shown as a short linear interpolation of the joints, drawn
in a scratch copy of the state and marked as such in the overlay. After every move the frame
holds for a moment with the detected marker, the trail of the marker's detections so far and
the error in mm: the ground-truth distance of the sensed point from the target, called "error"
in every overlay, during the move as after it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from envs.composite import CompositeView
from envs.harness.trials import Trial, run_trial
from envs.harness.video import annotate
from envs.robots import ROBOTS
from learners.base import Controller

VIDEO_FPS = 30.0  # frames per second of the video
HOLD_SECONDS = 0.7  # s of video that each move's result (and the new target) stays on screen
INTERPOLATION_SECONDS = 0.5  # s of video that an interpolated kinematic move takes
#: Panel size (width, height) of films: three panels side by side are 1800 pixels wide, and two
#: films one above the other fit a full-HD screen.
FILM_PANEL = (600, 450)
MM_PER_M = 1e3

#: A film's frames, one list per stage: the new target, then each move.
Stages = list[list[np.ndarray]]


def move_name(k: int) -> str:
    return "coarse move" if k == 0 else f"fine move {k}"


class TrialFilm:
    """Films trials of one reach env (``render`` needs no ``render_mode``).

    Args:
        env: a ReachEnv or a wrapper of one.
        title: the first overlay line of every frame (env, controller, settings).
        fps: frames per second of the video.
        speed: simulated seconds per second of video (1: real time).
        panel: (width, height) of each of the three panels.
        zoom: magnify the target's neighbourhood in the camera views (default: for a robot whose
            arm is small in its cameras, :attr:`envs.robots.RobotSpec.magnify`: RIACS).
        text_scale: OpenCV font scale of every overlay's text (default: in proportion to the
            panel height); larger for frames shown small, as the docs' GIFs are.
    """

    def __init__(
        self,
        env,
        title: str,
        fps: float = VIDEO_FPS,
        speed: float = 1.0,
        panel: tuple[int, int] = FILM_PANEL,
        zoom: bool | None = None,
        text_scale: float | None = None,
    ) -> None:
        self.env, self.base, self.title = env, env.unwrapped, title
        self.fps, self.speed = fps, speed
        zoom = ROBOTS[self.base.robot].magnify if zoom is None else zoom
        sensing_size = (self.base.image_width, self.base.image_height)
        self.view = CompositeView(
            self.base.model, panel[1], panel[0], sensing_size, zoom, text_scale
        )
        self.text_scale = panel[1] / 600 if text_scale is None else text_scale
        self._scratch = mujoco.MjData(self.base.model)  # interpolated kinematic poses

    def trial(self, controller: Controller, fine_moves: int, label: str) -> tuple[Trial, Stages]:
        """Run one trial (:func:`envs.harness.trials.run_trial`) and film it.

        Args:
            label: the trial's name in the overlay, e.g. "trial 2/5".
        Returns:
            the trial, and its frames: the new target, then one list per move made.
        """
        stages: Stages = []
        moving: list[np.ndarray] = []  # frames of the move under way
        state = {"qpos": self.base.data.qpos.copy(), "next": 0.0, "k": 0}
        trial_box: list[Trial] = []

        def on_step(elapsed: float) -> None:
            if elapsed + 1e-12 < state["next"]:
                return
            state["next"] += self.speed / self.fps
            trial = trial_box[0]
            distance = self._distance(self.base.data, trial)
            status = f"moving, t = {elapsed:.2f} s   error {distance * MM_PER_M:.1f} mm"
            moving.append(self._frame(self.base.data, trial, label, state["k"], status, False))

        def on_move(k: int, trial: Trial) -> None:
            if k < 0:
                trial_box.append(trial)
                state["qpos"] = self.base.data.qpos.copy()
                frame = self._frame(self.base.data, trial, label, -1, "new target", False)
                stages.append([frame] * self._frames(HOLD_SECONDS))
                return
            if self.base.control == "kinematic":
                moving.extend(self._interpolate(state["qpos"], trial, label, k))
            error = f"error {trial.distances[k] * MM_PER_M:.1f} mm"
            seen = "" if trial.visible[k] else "   marker not seen"
            end = self._frame(self.base.data, trial, label, k, error + seen, True)
            stages.append([*moving, *[end] * self._frames(HOLD_SECONDS)])
            moving.clear()
            state.update(qpos=self.base.data.qpos.copy(), next=0.0, k=k + 1)

        self.base.on_physics_step = on_step if self.base.control == "servo" else None
        try:
            trial = run_trial(self.env, controller, fine_moves, on_move=on_move)
        finally:
            self.base.on_physics_step = None
        return trial, stages

    def _frames(self, seconds: float) -> int:
        return max(1, round(seconds * self.fps))

    def _distance(self, data, trial: Trial) -> float:
        """Ground-truth distance (m) of the sensed point from the target in ``data``."""
        return float(np.linalg.norm(self.base.sensed_point(data) - trial.target_pos))

    def _interpolate(self, start: np.ndarray, trial: Trial, label: str, k: int) -> list:
        """Frames of the joints going linearly from ``start`` to the env's current pose."""
        scratch, end = self._scratch, self.base.data.qpos.copy()
        scratch.mocap_pos[:] = self.base.data.mocap_pos
        scratch.mocap_quat[:] = self.base.data.mocap_quat
        frames = []
        n = self._frames(INTERPOLATION_SECONDS)
        for s in np.linspace(0.0, 1.0, n + 1)[1:]:
            scratch.qpos[:] = (1 - s) * start + s * end
            mujoco.mj_kinematics(self.base.model, scratch)
            mujoco.mj_camlight(self.base.model, scratch)
            status = "kinematic move: joints interpolated for the eye, not simulated"
            frames.append(self._frame(scratch, trial, label, k, status, False))
        return frames

    def _frame(
        self, data, trial: Trial, label: str, k: int, status: str, sensed: bool
    ) -> np.ndarray:
        """One annotated frame; ``sensed``: draw the detection after move ``k``."""
        made = len(trial.sensed_px) if sensed else min(k, len(trial.sensed_px))
        trail = trial.sensed_px[:made]
        effector = trail[-1] if sensed and trail else np.full(4, np.nan)
        image = self.view.render(data, trial.target_px, effector, trail)
        stage = "" if k < 0 else move_name(k)  # k < 0: the status says "new target"
        lines = [self.title, "   ".join(part for part in (label, stage, status) if part)]
        return annotate(image, lines, scale=self.text_scale)

    def close(self) -> None:
        self.view.close()


def side_by_side(films: list[Stages], gap: int = 6) -> list[np.ndarray]:
    """Films of the same trial, one above the other, stage by stage: a film whose stage is
    shorter holds its last frame (a stage a film did not reach holds its last frame too)."""
    frames = []
    for s in range(max(len(f) for f in films)):
        parts = [f[s] if s < len(f) else f[-1][-1:] for f in films]
        for i in range(max(len(p) for p in parts)):
            rows = [p[min(i, len(p) - 1)] for p in parts]
            if len(rows) == 1:  # one film: its frames as they are
                frames.append(rows[0])
                continue
            width = max(r.shape[1] for r in rows)
            spacer = np.full((gap, width, 3), 255, dtype=np.uint8)
            stacked = [rows[0]]
            for row in rows[1:]:
                stacked += [spacer, row]
            frames.append(np.concatenate(stacked, axis=0))
    return frames
