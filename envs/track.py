"""PumaTrack-v0: the PUMA 560 tool centre point follows a path by small joint increments.

The episode runner shared by training and evaluation is in :mod:`envs.harness.tracking`.
"""

from __future__ import annotations

from typing import Any, ClassVar

import cv2
import numpy as np
from gymnasium import spaces

from envs import arguments
from envs.scene import IMAGE_HEIGHT, IMAGE_WIDTH, ArmScene
from envs.sensing.marker_detection import GREEN_EFFECTOR
from envs.sensing.rendering import GROUP_MARKER, GROUP_ROBOT, GROUP_SCENE, CameraRenderer
from envs.sensing.stereo import PinholeCamera
from models.paths import DT, N_STEPS, PATH_KINDS, Path, sample_path
from models.puma560 import DH
from models.rotations import orientation_error

SENSING_MODES = ("project", "render")
PATH_CHOICES = (*PATH_KINDS, "any")
#: Largest joint increment per step, each joint (rad); actions are clipped to it. Paths need at
#: most half of it (``models.paths.MAX_SAMPLE_JOINT_STEP``), leaving room for corrections.
MAX_JOINT_STEP = 0.1
#: A step succeeds when the TCP is this close to the path point in position (m) and angle (rad).
SUCCESS_POSITION = 0.002
SUCCESS_ORIENTATION = np.deg2rad(1.0)
#: Image size (height, width) of ``render()`` frames, pixels.
RENDER_SIZE = (480, 640)
#: Observation bounds: positions (m) and velocities (m/s, rad/s) far outside anything reachable,
#: and rotation-matrix entries (1 plus room for rounding).
POSITION_BOUND, VELOCITY_BOUND, ROTATION_BOUND = 5.0, 100.0, 1.0 + 1e-9
#: Colours (RGB) of the drawn path and of the TCP trace.
PATH_COLOUR, TRACE_COLOUR = (255, 220, 0), (0, 200, 255)


class PumaTrackEnv(ArmScene):
    r"""The 6-joint PUMA 560 follows a circle or a straight line with an orientation profile.

    ## Description
    A path (``models.paths``: a circle or a line inside the PUMA workspace box, ``n_steps``
    samples ``dt`` seconds apart, each with a tool orientation) is drawn at reset; the arm starts
    exactly on its first pose. Each step the agent sends a joint increment, the env sets the
    joints (**kinematic control**: qpos is written and the kinematics recomputed, no dynamics) and
    reports the TCP pose: the **position from the stereo rig** (the ``tcp`` site projected into
    ``cam_left``/``cam_right`` and triangulated; with ``sensing="render"`` both cameras are drawn
    and the green ``marker_tcp`` is detected instead) and the **orientation from the simulator**
    (the ``tcp`` site frame). It also reports the path's next point and the desired velocity there.

    ## Action space
    ``Box(-MAX_JOINT_STEP, MAX_JOINT_STEP, (6,), float64)``: joint increments Δθ1..Δθ6 (rad),
    clipped to ±0.1 rad, and the result clipped to the joint ranges of ``models.puma560.DH``.
    A wrong shape, NaN or inf raises ``ValueError``, and so do bools, strings and complex numbers
    (integers are numbers); ``step`` before ``reset`` raises ``gymnasium.error.ResetNeeded``.

    ## Observation space (``Dict``, float64)
    | key | shape | meaning | unit |
    |-----|-------|---------|------|
    | ``joints`` | (6,) | joint angles θ1..θ6 (= qpos) | rad |
    | ``tcp_pos`` | (3,) | sensed TCP position, world frame (last sighting if not visible) | m |
    | ``tcp_rot`` | (9,) | TCP rotation matrix, row-major, columns = tool axes in world | - |
    | ``target_pos`` | (3,) | next path point, world frame | m |
    | ``target_rot`` | (9,) | tool rotation at the next path point, row-major | - |
    | ``target_vel`` | (6,) | desired linear and angular (world) velocity there | m/s, rad/s |

    ## Rewards
    ``reward = reward_position = -‖p_tcp - p_target‖`` (m): ground-truth distance of the TCP site
    from the path point the step aimed at.

    ## Info
    ``position_error`` (m), ``orientation_error`` (rad, angle of R_target·Rᵀ), ``reward_position``,
    ``is_success`` (position ≤ 2 mm and orientation ≤ 1°), ``visible`` (marker seen by both
    cameras; always True for ``"project"``), ``tcp_pos_true`` (m), ``step`` (path index reached).

    ## Starting state and episode end
    Joints at the path's inverse-kinematics solution for its first pose. Never terminates;
    truncated after ``n_steps`` steps, when the path's last point has been the target.

    ## Arguments
    | argument | default | meaning |
    |----------|---------|---------|
    | ``render_mode`` | None | ``"rgb_array"``: overview camera with the path and TCP trace drawn |
    | ``sensing`` | ``"project"`` | ``"project"`` (exact pinhole) or ``"render"`` (detection) |
    | ``path_kind`` | ``"any"`` | ``"circle"``, ``"line"`` or ``"any"`` (either, equally likely) |
    | ``n_steps`` | 100 | steps per path (one revolution of a circle) |
    | ``dt`` | 0.04 | control period, s (sets the desired velocities) |
    | ``circle_radius`` | None | fixed circle radius (m); None draws it from ``models.paths`` |

    ``reset(options={"path": path})`` tracks a given :class:`models.paths.Path` instead.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 25}

    def __init__(
        self,
        render_mode: str | None = None,
        sensing: str = "project",
        path_kind: str = "any",
        n_steps: int = N_STEPS,
        dt: float = DT,
        circle_radius: float | None = None,
    ) -> None:
        if sensing not in SENSING_MODES:
            raise ValueError(f"sensing must be one of {SENSING_MODES}, got {sensing!r}")
        if path_kind not in PATH_CHOICES:
            raise ValueError(f"path_kind must be one of {PATH_CHOICES}, got {path_kind!r}")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        n_steps = arguments.positive_int("n_steps", n_steps)
        dt = arguments.positive_number("dt (s)", dt)
        if circle_radius is not None:
            circle_radius = arguments.positive_number("circle_radius (m)", circle_radius)
        self.render_mode, self.sensing, self.path_kind = render_mode, sensing, path_kind
        self.n_steps, self.dt, self.circle_radius = n_steps, dt, circle_radius
        # All six joints: the sensed point is the tcp, and only its marker is drawn (the wrist
        # marker would merge with it in the images).
        super().__init__("puma560", 6, IMAGE_WIDTH, IMAGE_HEIGHT)
        self._overview: CameraRenderer | None = None
        bound = np.full(6, MAX_JOINT_STEP)
        self.action_space = spaces.Box(-bound, bound, dtype=np.float64)

        def box(n: int, bound: float) -> spaces.Box:
            return spaces.Box(-bound, bound, (n,), dtype=np.float64)

        self.observation_space = spaces.Dict(
            {
                "joints": spaces.Box(DH.lower, DH.upper, dtype=np.float64),
                "tcp_pos": box(3, POSITION_BOUND),
                "tcp_rot": box(9, ROTATION_BOUND),
                "target_pos": box(3, POSITION_BOUND),
                "target_rot": box(9, ROTATION_BOUND),
                "target_vel": box(6, VELOCITY_BOUND),
            }
        )
        self.path: Path | None = None
        self._k = 0
        self._sensed = np.zeros(3)
        self.trace: list[np.ndarray] = []

    # -- sensing ------------------------------------------------------------------------------
    def _sense(self) -> bool:
        """Update the sensed TCP position; returns whether both cameras saw it."""
        if self.sensing == "project":
            pixels = self.stereo.project(self.sensed_point())
        else:
            pixels, visible = self.stereo.sense(self.data, GREEN_EFFECTOR, self.marker_radius)
            if not visible.all():
                return False
        self._sensed = self.stereo.triangulate(pixels)[0]
        return True

    def _obs(self) -> dict[str, np.ndarray]:
        j = min(self._k + 1, self.path.n_steps)
        return {
            "joints": self.data.qpos[:6].copy(),
            "tcp_pos": self._sensed.copy(),
            "tcp_rot": self.data.site_xmat[self._site].copy(),
            "target_pos": self.path.positions[j].copy(),
            "target_rot": self.path.rotations[j].ravel().copy(),
            "target_vel": self.path.twist(j),
        }

    def _info(self, visible: bool) -> dict[str, Any]:
        k = self._k
        p = self.sensed_point()
        pos_err = float(np.linalg.norm(p - self.path.positions[k]))
        rot = self.data.site_xmat[self._site].reshape(3, 3)
        ori_err = float(np.linalg.norm(orientation_error(self.path.rotations[k], rot)))
        return {
            "position_error": pos_err,
            "orientation_error": ori_err,
            "reward_position": -pos_err,
            "visible": visible,
            "tcp_pos_true": p,
            "step": k,
            "is_success": pos_err <= SUCCESS_POSITION and ori_err <= SUCCESS_ORIENTATION,
        }

    # -- gymnasium API ------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        options = arguments.reset_options(
            options, {"path": lambda p: isinstance(p, Path)}, "{'path': models.paths.Path}"
        )
        super().reset(seed=seed)
        if "path" in options:
            self.path = options["path"]
        else:
            kind = self.path_kind
            if kind == "any":
                kind = PATH_KINDS[int(self.np_random.integers(len(PATH_KINDS)))]
            self.path = sample_path(
                self.np_random, kind, self.n_steps, self.dt, radius=self.circle_radius
            )
        self._k = 0
        self.set_joints(self.path.joints[0])
        visible = self._sense()
        if not visible:  # first sighting failed: start from the true position, say so in info
            self._sensed = self.sensed_point()
        self.trace = [self.sensed_point()]
        return self._obs(), self._info(visible)

    def step(self, action: np.ndarray):
        self.require_reset()
        action = arguments.real_numbers("action", action, "real numbers (rad)")
        if action.shape != (6,) or not np.isfinite(action).all():
            raise ValueError(f"action must be 6 finite joint increments (rad), got {action!r}")
        delta = np.clip(action, -MAX_JOINT_STEP, MAX_JOINT_STEP)
        self.set_joints(np.clip(self.data.qpos[:6] + delta, DH.lower, DH.upper))
        visible = self._sense()
        self._k = min(self._k + 1, self.path.n_steps)
        self.trace.append(self.sensed_point())
        info = self._info(visible)
        truncated = self._k >= self.path.n_steps
        return self._obs(), info["reward_position"], False, truncated, info

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        height, width = RENDER_SIZE
        if self._overview is None:
            self._overview = CameraRenderer(self.model, height, width, fast=False)
        frame = self._overview.render(
            self.data, "overview", (GROUP_SCENE, GROUP_ROBOT, GROUP_MARKER)
        )
        camera = PinholeCamera.from_model(self.model, self.data, "overview", height, width)
        frame = np.ascontiguousarray(frame)
        for points, colour in (
            (self.path.positions, PATH_COLOUR),
            (np.array(self.trace), TRACE_COLOUR),
        ):
            uv = camera.project(points)
            cv2.polylines(frame, [np.round(uv).astype(np.int32)], False, colour, 1, cv2.LINE_AA)
        return frame

    def close(self) -> None:
        if self._overview is not None:
            self._overview.close()
            self._overview = None
        super().close()
