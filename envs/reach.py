"""ReachEnv: move the arm so that its marker reaches a target that two cameras see."""

from __future__ import annotations

import math
from typing import Any, ClassVar

import gymnasium as gym
import mujoco
import numpy as np

from envs import arguments
from envs.composite import CompositeView
from envs.markers import GREEN_EFFECTOR, RED_TARGET
from envs.perturb import Perturbation, SceneEditor
from envs.robots import ROBOTS, RobotSpec
from envs.stereo import CameraPair, StereoRig
from models import load_model

SENSING_MODES = ("render", "project")
CONTROL_MODES = ("servo", "kinematic")
SUCCESS_THRESHOLD = 0.005  # m
IMAGE_HEIGHT, IMAGE_WIDTH = 240, 320  # sensing images, pixels
SETTLE_SPEED = 1e-3  # rad/s: the servo move ends when every joint is slower than this ...
SETTLE_WINDOW = 0.02  # s ... for this long (not just at a turning point of an oscillation) ...
MIN_SETTLE_TIME = 0.02  # s ... after at least this much simulated time,
MAX_SETTLE_TIME = 2.0  # s ... or at this cap.
MAX_EPISODE_STEPS = 4  # moves: one coarse and up to three fine
#: ``reset(options=...)`` keys and the test each value must pass.
RESET_OPTIONS = {
    "keep_arm": lambda value: isinstance(value, (bool, np.bool_)),
    "perturb": lambda value: value is None or isinstance(value, (Perturbation, dict)),
}


class ReachEnv(gym.Env):
    """Reach a target with a robot arm, seen only through two cameras.

    The robot is a PUMA 560 (``PumaReach-v0``) or the RIACS 3-DOF arm (``RiacsReach-v0``). A red
    target sphere is placed in the robot's workspace; a green marker sits at the arm's sensed point
    (PUMA: the wrist centre when joints 1-3 are controlled, the tool point when all six are; RIACS:
    the tool point). Two fixed cameras ``cam_left`` and ``cam_right`` see both. One step is one
    *move*: the action is an absolute joint command, the arm goes there, and the cameras sense
    where the marker ended up.

    ## Action space
    ``Box(joint_lower, joint_upper, (J,), float64)``: absolute command in radians for the
    controlled joints (J = 3, or 6 for ``PumaReach-v0`` with ``joints=6``). A command outside a
    joint's range is clipped into it and ``info["clipped"]`` is True. NaN or inf raises
    ``ValueError`` naming the joint; a wrong shape raises ``ValueError`` with the expected shape.

    ## Observation space
    ``Dict`` in the Gymnasium-Robotics goal convention:

    | key | shape | unit | meaning |
    |---|---|---|---|
    | ``observation`` | (J,) | rad | joint angles of the controlled joints |
    | ``achieved_goal`` | (4,) | px | sensed marker centre (u_left, v_left, u_right, v_right) |
    | ``desired_goal`` | (4,) | px | sensed target centre, same layout |

    Pixels are array-index coordinates (u right, v down) of 320×240 images (``image_size``).
    The target is sensed once per episode, at reset, with the robot out of view; the effector
    marker after every move, with the robot (which may occlude it) but without the target (which
    it would hide). A marker that is not seen by both cameras (occluded, cut by the image border)
    keeps its last valid sensing in the observation and ``info["visible"]`` is False; before a
    marker has ever been seen its entry is the image centre.

    ## Reward
    ``reward = -info["distance"]``: minus the ground-truth distance in metres between the target
    centre and the sensed site (from MuJoCo, not from the cameras). ``info["reward_distance"]``
    holds the same term. ``compute_reward(achieved_goal, desired_goal, info)`` gives minus the
    distance between the triangulated goals, for goal-relabelling (HER) agents; it equals the
    step reward with ``sensing="project"``.

    ## Starting state
    ``reset`` draws a target uniformly from the robot's workspace with ``self.np_random`` and moves
    the mocap body there. The arm returns to the keyframe ``home`` unless
    ``reset(options={"keep_arm": True})`` leaves it where the last move put it.
    ``reset(options={"perturb": change})`` first applies :meth:`perturb`.

    ## Changes of the scene
    ``perturb(change)`` moves, turns and zooms the cameras, moves the sensed point along the arm
    and shifts the base at run time (:mod:`envs.perturb`); sensing, ``info`` and the rendered
    views follow, ``stereo`` re-reads its cameras, and ``nominal_stereo`` keeps the cameras as
    built (what the exact baselines triangulate with).

    ## Episode end
    Never terminates; truncated after ``max_episode_steps`` moves (registered default 4: one
    coarse and three fine).

    ## Info
    ``distance`` (m), ``reward_distance`` (= reward), ``pixel_error`` (px, mean over the two
    cameras of the image distance between achieved and desired goal), ``is_success``
    (distance < ``success_threshold``), ``visible`` (both markers seen by both cameras),
    ``visible_target`` and ``visible_effector`` ((2,) bool, per camera), ``target_pos`` and
    ``effector_pos`` (world, m), ``clipped`` (bool), ``settle_time`` (s of simulated time the
    move took; 0 for kinematic control).

    ## Arguments
    - ``robot`` (``"riacs"``): ``"riacs"`` or ``"puma560"``.
    - ``joints`` (3): controlled joints (PUMA: 3 or 6; the others are held at ``home``).
    - ``sensing`` (``"render"``): ``"render"`` draws both cameras off-screen and finds the markers
      by colour (OpenCV); ``"project"`` is the exact pinhole projection with the same cameras.
    - ``control`` (``"servo"``): ``"servo"`` runs the position actuators until every joint is
      slower than 1e-3 rad/s for 0.02 s (at least 0.02 s, at most 2 s of simulated time);
      ``"kinematic"`` sets the joints.
    - ``success_threshold`` (0.005): metres.
    - ``image_size`` ((240, 320)): (height, width) of the sensing images in pixels; larger
      images sense more precisely (the cameras' field of view stays the same) and render slower.
    - ``render_mode`` (None): ``"rgb_array"`` gives the left view, the right view and the
      overview side by side, with the target crosshair and the detected marker drawn.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(
        self,
        robot: str = "riacs",
        joints: int = 3,
        sensing: str = "render",
        control: str = "servo",
        success_threshold: float = SUCCESS_THRESHOLD,
        image_size: tuple[int, int] = (IMAGE_HEIGHT, IMAGE_WIDTH),
        render_mode: str | None = None,
    ) -> None:
        if not isinstance(robot, str) or robot not in ROBOTS:
            raise ValueError(f"unknown robot {robot!r}; valid robots: {', '.join(ROBOTS)}")
        self.spec_robot: RobotSpec = ROBOTS[robot]
        if isinstance(joints, bool) or joints not in self.spec_robot.joint_options:
            raise ValueError(
                f"{robot} can control {self.spec_robot.joint_options} joints, not {joints!r}"
            )
        if not isinstance(sensing, str) or sensing not in SENSING_MODES:
            raise ValueError(f"unknown sensing {sensing!r}; valid: {', '.join(SENSING_MODES)}")
        if not isinstance(control, str) or control not in CONTROL_MODES:
            raise ValueError(f"unknown control {control!r}; valid: {', '.join(CONTROL_MODES)}")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"unknown render_mode {render_mode!r}; valid: None, 'rgb_array'")
        height, width = arguments.image_size(image_size)
        self.image_height, self.image_width = height, width
        arguments.positive_number("success_threshold (m)", success_threshold)
        self.robot, self.joints, self.sensing, self.control = robot, joints, sensing, control
        self.success_threshold = float(success_threshold)
        self.render_mode = render_mode

        self.model = load_model(robot)
        self.data = mujoco.MjData(self.model)
        self._home = self.model.key("home").id
        self._joint_ids = np.array([self.model.joint(f"joint{i + 1}").id for i in range(joints)])
        self._qpos_ids = self.model.jnt_qposadr[self._joint_ids]
        self._actuator_ids = np.array(
            [self.model.actuator(f"joint{i + 1}").id for i in range(joints)]
        )
        self.joint_lower = self.model.jnt_range[self._joint_ids, 0].copy()
        self.joint_upper = self.model.jnt_range[self._joint_ids, 1].copy()
        self._site = self.model.site(self.spec_robot.sensed[joints]).id
        self._show_only_marker(self.spec_robot.markers[joints])
        marker = self.model.geom(self.spec_robot.markers[joints]).id
        self._marker_radius = float(self.model.geom_size[marker][0])  # m
        mujoco.mj_resetDataKeyframe(self.model, self.data, self._home)
        mujoco.mj_forward(self.model, self.data)
        self.stereo = StereoRig(self.model, self.data, height, width)
        self.nominal_stereo = CameraPair(self.stereo.cameras)  # the baselines' calibration
        self._scene = SceneEditor(
            self.model,
            self.data,
            robot,
            self.spec_robot.sensed[joints],
            self.spec_robot.markers[joints],
            self.nominal_stereo,
            (height, width),
        )
        self.perturbation = Perturbation()
        self._view = CompositeView(self.model, height, width)

        self.action_space = gym.spaces.Box(self.joint_lower, self.joint_upper, dtype=np.float64)
        pixels = gym.spaces.Box(-np.inf, np.inf, shape=(4,), dtype=np.float64)
        self.observation_space = gym.spaces.Dict(
            {
                "observation": gym.spaces.Box(self.joint_lower, self.joint_upper, dtype=np.float64),
                "achieved_goal": pixels,
                "desired_goal": pixels,
            }
        )
        centre = np.tile([(width - 1) / 2, (height - 1) / 2], 2)
        self._last = {"target": centre.copy(), "effector": centre.copy()}
        self._visible_target = np.zeros(2, dtype=bool)
        self._visible_effector = np.zeros(2, dtype=bool)
        self._detected_target = np.full(4, np.nan)
        self._detected_effector = np.full(4, np.nan)

    # -- Gymnasium API -------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        options = arguments.reset_options(
            options, RESET_OPTIONS, "{'keep_arm': bool, 'perturb': Perturbation | dict | None}"
        )
        super().reset(seed=seed)
        if "perturb" in options:
            self.perturb(options["perturb"])
        target = self.spec_robot.workspace.sample(self.np_random, 1)[0]
        target = target + self.perturbation.base_shift
        if options.get("keep_arm", False):
            self.data.qvel[:] = 0.0
        else:
            mujoco.mj_resetDataKeyframe(self.model, self.data, self._home)
        self.data.mocap_pos[0] = target
        mujoco.mj_forward(self.model, self.data)
        self._sense_target()
        self._sense_effector()
        return self._observation(), self._info(clipped=False, settle_time=0.0)

    def step(self, action: np.ndarray):
        command, clipped = self._check_action(action)
        settle_time = self._move(command)
        self._sense_effector()
        info = self._info(clipped=clipped, settle_time=settle_time)
        return self._observation(), -info["distance"], False, False, info

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray:
        """Minus the distance (m) between triangulated goals; works on batches (..., 4)."""
        a, d = np.asarray(achieved_goal, float), np.asarray(desired_goal, float)
        shape = np.broadcast_shapes(a.shape, d.shape)[:-1]
        pa = self.stereo.triangulate(np.broadcast_to(a, (*shape, 4)).reshape(-1, 4))
        pd = self.stereo.triangulate(np.broadcast_to(d, (*shape, 4)).reshape(-1, 4))
        return -np.linalg.norm(pa - pd, axis=-1).reshape(shape)

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        return self._view.render(self.data, self._last["target"], self._detected_effector)

    def close(self) -> None:
        self.stereo.close()
        self._view.close()

    def perturb(
        self,
        change: Perturbation | dict[str, Any] | None = None,
        *,
        random: dict[str, float] | None = None,
        seed: int | None = None,
    ) -> Perturbation:
        """Change the scene between trials, relative to the nominal scene (see
        :class:`envs.perturb.Perturbation`); ``nominal_stereo`` keeps the nominal cameras.

        Args:
            change: a Perturbation or a dict of its fields; None restores the nominal scene.
            random: instead, sizes for :meth:`Perturbation.random`, drawn with a generator of
                ``seed`` (default: the env's ``np_random``, seeded by ``reset(seed=...)``).
        Returns:
            the change now in effect; the next reset senses a target in the changed scene.
        Raises:
            PerturbationError: a change that is not finite, too large, or takes the workspace
                out of view; nothing has changed then.
        """
        if random is not None:
            if change is not None:
                raise ValueError("pass either a change or random sizes, not both")
            rng = self.np_random if seed is None else np.random.default_rng(seed)
            change = Perturbation.random(rng, **random)
        change = Perturbation.of(change)
        self._scene.check(change, self.spec_robot.workspace)
        self._scene.apply(change)
        mujoco.mj_forward(self.model, self.data)
        self.stereo.refresh(self.data)
        self.perturbation = change
        return change

    def sensed_target(self) -> np.ndarray:
        """Target pixels (4,) sensed at the last reset; NaN in a camera that did not see it."""
        return self._detected_target.copy()

    def sensed_effector(self) -> np.ndarray:
        """Marker pixels (4,) sensed after the last move; NaN in a camera that did not see it."""
        return self._detected_effector.copy()

    # -- internals -----------------------------------------------------------------------------

    @property
    def reach(self) -> float:
        """The robot's reach in metres, for errors in % of the robot's size."""
        return self.spec_robot.reach

    def _show_only_marker(self, keep: str) -> None:
        """Hide the effector markers of the other joint options (group 5 is never drawn)."""
        for name in set(self.spec_robot.markers.values()) - {keep}:
            self.model.geom_group[self.model.geom(name).id] = 5

    def _check_action(self, action: np.ndarray) -> tuple[np.ndarray, bool]:
        a = arguments.real_array("action", action)
        if a.shape != (self.joints,):
            raise ValueError(
                f"action must have shape ({self.joints},) (joint1..joint{self.joints} in rad), "
                f"got shape {a.shape}"
            )
        if not np.isfinite(a).all():
            bad = int(np.flatnonzero(~np.isfinite(a))[0])
            raise ValueError(f"action for joint{bad + 1} is {a[bad]}; commands must be finite")
        command = np.minimum(np.maximum(a, self.joint_lower), self.joint_upper)
        return command, bool((command != a).any())

    def _move(self, command: np.ndarray) -> float:
        if self.control == "kinematic":
            self.data.qpos[self._qpos_ids] = command
            self.data.qvel[:] = 0.0
            mujoco.mj_forward(self.model, self.data)
            return 0.0
        self.data.ctrl[self._actuator_ids] = command
        start = self.data.time
        slow_since = None  # s, when every joint last became slower than SETTLE_SPEED
        while True:
            mujoco.mj_step(self.model, self.data)
            elapsed = self.data.time - start
            if np.max(np.abs(self.data.qvel)) >= SETTLE_SPEED:
                slow_since = None
            elif slow_since is None:
                slow_since = elapsed
            settled = slow_since is not None and elapsed - slow_since >= SETTLE_WINDOW
            if (elapsed >= MIN_SETTLE_TIME and settled) or elapsed >= MAX_SETTLE_TIME:
                return float(elapsed)

    def _sense_target(self) -> None:
        pixels, visible = self._sense(self.data.mocap_pos[0], RED_TARGET)
        self._visible_target = visible
        self._detected_target = pixels
        if visible.all():
            self._last["target"] = pixels

    def _sense_effector(self) -> None:
        pixels, visible = self._sense(
            self.data.site_xpos[self._site], GREEN_EFFECTOR, self._marker_radius
        )
        self._visible_effector = visible
        self._detected_effector = pixels
        if visible.all():
            self._last["effector"] = pixels

    def _sense(
        self, point: np.ndarray, colour, radius: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        if self.sensing == "render":
            return self.stereo.sense(self.data, colour, radius)
        pixels, depth = self.stereo.project_with_depth(point)
        (u1, v1, u2, v2), (d1, d2) = pixels[0].tolist(), depth[0].tolist()
        u_max, v_max = self.image_width - 1, self.image_height - 1
        visible = np.array(
            [d1 > 0 and 0 <= u1 <= u_max and 0 <= v1 <= v_max,
             d2 > 0 and 0 <= u2 <= u_max and 0 <= v2 <= v_max]
        )  # fmt: skip
        return np.where(np.repeat(visible, 2), pixels[0], np.nan), visible

    def _observation(self) -> dict[str, np.ndarray]:
        return {
            "observation": self.data.qpos[self._qpos_ids].copy(),
            "achieved_goal": self._last["effector"].copy(),
            "desired_goal": self._last["target"].copy(),
        }

    def _info(self, clipped: bool, settle_time: float) -> dict[str, Any]:
        target = self.data.mocap_pos[0].copy()
        effector = self.data.site_xpos[self._site].copy()
        distance = math.dist(target, effector)
        du, dv, du2, dv2 = (self._last["effector"] - self._last["target"]).tolist()
        return {
            "distance": distance,
            "reward_distance": -distance,
            "pixel_error": 0.5 * (math.hypot(du, dv) + math.hypot(du2, dv2)),
            "is_success": distance < self.success_threshold,
            "visible": bool(self._visible_target.all() and self._visible_effector.all()),
            "visible_target": self._visible_target.copy(),
            "visible_effector": self._visible_effector.copy(),
            "target_pos": target,
            "effector_pos": effector,
            "clipped": clipped,
            "settle_time": settle_time,
        }
