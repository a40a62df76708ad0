"""ReachEnv: move the arm so that its marker reaches a target that two cameras see."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, ClassVar

import gymnasium as gym
import mujoco
import numpy as np

from envs import arguments
from envs.composite import CompositeView
from envs.kernels import clip_command
from envs.perturb import Perturbation, PerturbationError, SceneEditor, random_sizes
from envs.reward import GoalPoints, reward_terms, seen_flags, total_reward
from envs.robots import MarkerSet, RobotSpec, reach_env_ids, robot_spec
from envs.scene import IMAGE_HEIGHT, IMAGE_WIDTH, ArmScene, as_slice
from envs.sensing import pinhole_kernels
from envs.sensing.camera_images import CameraImages
from envs.sensing.pixel_cameras import PixelRig
from envs.sensing.sensors import SENSING_MODES, make_sensor
from envs.sensing.stereo import CameraPair
from envs.sensing.triangulation import camera_floats
from envs.step_info import StepInfo
from envs.viewer import HumanViewer

CONTROL_MODES = ("servo", "kinematic")
#: The Gymnasium ids of the reach envs: every robot's of the registry (envs/robots.py).
REACH_ENV_IDS = reach_env_ids()
#: Observation modes: the keys each puts into the observation dict.
OBS_MODES = {
    "state": ("observation", "achieved_goal", "desired_goal"),
    "pixels": ("pixels_left", "pixels_right", "achieved_goal", "desired_goal"),
    "state_pixels": ("observation", "pixels_left", "pixels_right", "achieved_goal", "desired_goal"),
}
#: The image keys, in the order of the stereo rig's cameras (left, right).
PIXEL_KEYS = ("pixels_left", "pixels_right")
PIXELS_WIDTH = PIXELS_HEIGHT = 84  # px, each camera's image with obs_mode "pixels"
SUCCESS_THRESHOLD = 0.005  # m
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


#: px: a marker sphere's image this far outside both images is not rendered (it is not seen).
OUT_OF_VIEW_PX = 4.0


def moving_numpy(qvel: np.ndarray) -> bool:
    """Whether some joint is at least SETTLE_SPEED fast: ``max |qvel| >= SETTLE_SPEED`` (rad/s),
    False when a speed is NaN. The reference of :func:`moving`."""
    return bool(np.max(np.abs(qvel)) >= SETTLE_SPEED)


def moving(qvel: np.ndarray) -> bool:
    """:func:`moving_numpy` on the speeds as Python floats (a servo move tests it after every
    physics step; two numpy reductions of a few numbers cost more than the step)."""
    speeds = qvel.tolist()
    if max(speeds) >= SETTLE_SPEED or min(speeds) <= -SETTLE_SPEED:
        return not any(map(math.isnan, speeds))  # a NaN makes numpy's maximum NaN
    return False


class ReachEnv(ArmScene):
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
    ``ValueError`` naming the joint; a wrong shape raises ``ValueError`` with the expected shape;
    bools, strings and complex numbers raise ``ValueError`` (integers are numbers: a float64
    ``Box`` contains integer arrays). ``step`` before ``reset`` raises
    ``gymnasium.error.ResetNeeded``, on the unwrapped env too.

    ## Observation space
    ``Dict`` in the Gymnasium-Robotics goal convention:

    | key | shape | unit | meaning |
    |---|---|---|---|
    | ``observation`` | (J,) | rad | joint angles of the controlled joints |
    | ``achieved_goal`` | (4,) | px | sensed marker centre (u_left, v_left, u_right, v_right) |
    | ``desired_goal`` | (4,) | px | sensed target centre, same layout |
    | ``pixels_left``, ``pixels_right`` | (H, W, 3) uint8 | | camera images (``obs_mode``) |

    Pixels are array-index coordinates (u right, v down) of 320×240 images (``width`` ×
    ``height``).
    Every entry is bounded: joints by their ranges (a servo move can overshoot a commanded limit
    by ~1e-4 rad; the observation is clipped into the range, ``data.qpos`` is not), goals by the
    image, [0, width - 1] × [0, height - 1] (a marker cut by the image border is not seen, so a
    sensed centre lies inside; the sub-pixel perspective correction is clipped). With
    ``normalize=True`` the action, the joints and the goals are each mapped affinely onto
    [-1, 1] (joint range; pixel 0 -> -1, width - 1 or height - 1 -> +1), and the action space
    is float32.
    The target is sensed once per episode, at reset, with the robot out of view; the effector
    marker after every move, with the robot (which may occlude it) but without the target (which
    it would hide). A marker that is not seen by both cameras (occluded, cut by the image border)
    keeps its last valid sensing in the observation and ``info["visible"]`` is False; before a
    marker has ever been seen its entry is the image centre.

    ``obs_mode="pixels"`` replaces ``observation`` by two camera images, ``"state_pixels"`` adds
    them to it: ``pixels_left`` and ``pixels_right``, each
    ``Box(0, 255, (pixels_height, pixels_width, 3), uint8)``, channel last, as Stable-Baselines3's
    CNN policies (``MultiInputPolicy``) take them. They come from the pixel cameras
    (``pixel_rig``, ``envs.sensing.pixel_cameras``), a stereo pair on the sensing cameras' side
    that frames the sensed point's reachable positions and the targets with a margin, not from
    the sensing cameras. They show floor, target, robot and marker, nothing the env sensed drawn
    on them; the target and marker spheres are drawn large enough to be seen (at least 2 px in
    radius), a target that the marker touches as a see-through shell. The goals stay the sensed
    pixels of the ``width`` × ``height`` sensing images, so goal relabelling (HER) works
    unchanged. One key per camera keeps each an ordinary RGB image (for viewing, recording,
    augmentation) and gives each its own CNN. Both are drawn into one off-screen buffer and read
    back at once after every reset and move.

    ## Reward
    ``reward = reward_distance + reward_unseen`` (m), computed from the observation alone, so that
    ``reward == compute_reward(obs["achieved_goal"], obs["desired_goal"], info)`` bit for bit in
    every setting, and goal-relabelling (HER) agents get the rewards the env would have given:

    - ``reward_distance``: minus the distance between the two goals triangulated by the stereo
      rig (``envs.reward``). With ``sensing="project"`` it is minus the ground-truth distance to
      ~1e-12 m; with ``"render"`` it carries the sensing error (measured in docs/sensing.md).
    - ``reward_unseen``: minus the robot's reach (RIACS 1.0 m, PUMA 0.86 m) when the effector
      marker was not seen by both cameras after the move (``info["visible_effector"]``; the
      achieved goal is then the last sighting, not where the arm is), else 0. It travels in
      ``info``, so a relabelled transition keeps it; ``compute_reward(..., info=None)`` takes
      every marker as seen. The target's visibility does not enter (the reward is relative to the
      desired goal as observed, which relabelling replaces).

    ``compute_reward`` takes goals of any batch shape (..., 4) with ``info`` as one dict, dicts
    shaped like the batch (list or object array, as HER passes them) or None. Success is judged
    on the ground truth: ``info["is_success"]`` is ``info["distance"] < success_threshold``.

    ## Starting state
    ``reset`` draws a target uniformly from the robot's workspace with ``self.np_random`` and moves
    the mocap body there. The arm returns to the keyframe ``home`` unless
    ``reset(options={"keep_arm": True})`` leaves it where the last move put it.
    ``reset(options={"perturb": change})`` first applies :meth:`perturb` (a refused change
    refuses the reset before it seeds ``np_random``).

    ## Changes of the scene
    ``perturb(change)`` moves, turns and zooms the cameras, moves the sensed point along the arm
    and shifts the base at run time (:mod:`envs.perturb`); sensing, ``info`` and the rendered
    views follow, ``stereo`` re-reads its cameras, and ``nominal_stereo`` keeps the cameras as
    built (what the exact baselines triangulate with).

    ## Episode end
    Never terminates unless ``terminate_on_success``; truncated after ``max_episode_steps``
    moves (registered default 4: one coarse and three fine).

    ## Info
    ``distance`` (m, ground truth), ``reward_distance`` and ``reward_unseen`` (m, the reward's
    terms), ``pixel_error`` (px, mean over the two
    cameras of the image distance between achieved and desired goal), ``is_success``
    (distance < ``success_threshold``), ``visible`` (both markers seen by both cameras),
    ``visible_target`` and ``visible_effector`` ((2,) bool, per camera), ``target_pos`` and
    ``effector_pos`` (world, m), ``clipped`` (bool), ``settle_time`` (s of simulated time the
    move took; 0 for kinematic control).

    ## Arguments
    - ``robot`` (``"riacs"``): ``"riacs"`` or ``"puma560"``.
    - ``joints`` (3): controlled joints (PUMA: 3 or 6; the others are held at ``home``).
    - ``sensing`` (``"render"``): ``"render"`` draws both cameras off-screen and finds the markers
      by colour (OpenCV); ``"project"`` is the exact pinhole projection with the same cameras;
      ``"foveated"`` renders each camera only in a small window about where the marker is
      expected (the target's pixels; the whole images when it is not there) at 4× the pixel
      density, and reports pixels of the base image (``envs.sensing.foveated``).
    - ``control`` (``"servo"``): ``"servo"`` runs the position actuators until every joint is
      slower than 1e-3 rad/s for 0.02 s (at least 0.02 s, at most 2 s of simulated time);
      ``"kinematic"`` sets the joints.
    - ``success_threshold`` (0.005): metres.
    - ``width`` (320): width of the sensing images in pixels.
    - ``height`` (240): their height. The size must have the cameras' aspect ratio 4:3
      (another shape raises ``envs.sizes.ImageSizeError`` naming both); larger images sense
      more precisely (the cameras' field of view stays the same) and render slower.
    - ``render_mode`` (None): ``"rgb_array"`` gives the left view, the right view and the
      overview side by side, with the target crosshair and the detected marker drawn.
      ``"human"`` shows the scene (target and marker included) in MuJoCo's viewer
      (``mujoco.viewer.launch_passive``, a GLFW window) after every reset and move, at most
      ``render_fps`` frames a second; it needs a display (a desktop or ``xvfb-run``), works with
      ``MUJOCO_GL=egl`` and raises ``envs.viewer.DisplayUnavailableError`` without a display.
    - ``obs_mode`` (``"state"``): ``"state"``, ``"pixels"`` or ``"state_pixels"`` (above).
    - ``pixels_width`` (84): width of each camera image of the pixel modes, in pixels.
    - ``pixels_height`` (84): their height. The pixel cameras frame the workspace at any ratio.
    - ``normalize`` (False): action, joints and goals in [-1, 1]. Off by default: radians and
      pixels are what the learners here and the baselines use, SB3's SAC/TD3 already rescale a
      bounded action space, and ``VecNormalize`` (or this option) fixes the observation scale.
      Turn it on for agents that do not rescale (PPO's Gaussian policy starts with σ = 1).
    - ``terminate_on_success`` (False): end the episode (``terminated``) at the first move whose
      ``info["is_success"]`` is true. Off by default: the papers' trial is a fixed coarse and
      fine moves, and ``gym.make`` truncates every episode after ``MAX_EPISODE_STEPS`` (4) moves.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array", "human"], "render_fps": 4}

    def __init__(
        self,
        robot: str | RobotSpec = "riacs",
        joints: int = 3,
        sensing: str = "render",
        control: str = "servo",
        success_threshold: float = SUCCESS_THRESHOLD,
        width: int = IMAGE_WIDTH,
        height: int = IMAGE_HEIGHT,
        render_mode: str | None = None,
        normalize: bool = False,
        obs_mode: str = "state",
        pixels_width: int = PIXELS_WIDTH,
        pixels_height: int = PIXELS_HEIGHT,
        terminate_on_success: bool = False,
    ) -> None:
        if not isinstance(terminate_on_success, bool):
            raise ValueError(f"terminate_on_success is {terminate_on_success!r}, not True or False")
        self.terminate_on_success = terminate_on_success
        spec = robot_spec(robot)  # a registry key, or a spec built at run time (ArmReach-v0)
        if isinstance(joints, bool) or joints not in spec.joint_options:
            raise ValueError(
                f"{spec.model} can control {spec.joint_options} joints, not {joints!r}"
            )
        if not isinstance(sensing, str) or sensing not in SENSING_MODES:
            raise ValueError(f"unknown sensing {sensing!r}; valid: {', '.join(SENSING_MODES)}")
        if not isinstance(control, str) or control not in CONTROL_MODES:
            raise ValueError(f"unknown control {control!r}; valid: {', '.join(CONTROL_MODES)}")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(
                f"unknown render_mode {render_mode!r}; valid: None, 'rgb_array', 'human'"
            )
        arguments.positive_number("success_threshold (m)", success_threshold)
        if not isinstance(obs_mode, str) or obs_mode not in OBS_MODES:
            raise ValueError(f"unknown obs_mode {obs_mode!r}; valid: {', '.join(OBS_MODES)}")
        pixels_size = (
            arguments.positive_int("pixels_width (px)", pixels_width),
            arguments.positive_int("pixels_height (px)", pixels_height),
        )
        super().__init__(spec, joints, width, height, self._task_markers(spec.model, joints))
        width, height = self.image_width, self.image_height
        #: Goal entries: 4 pixels (u_left, v_left, u_right, v_right) per marker.
        self.goal_size = 4 * len(self.markers.effector)
        self.robot, self.joints, self.sensing, self.control = spec.model, joints, sensing, control
        self.success_threshold = float(success_threshold)
        self.render_mode = render_mode

        self._actuator_ids = np.array(
            [self.model.actuator(f"joint{i + 1}").id for i in range(joints)]
        )
        self._ctrl = as_slice(self._actuator_ids)
        #: rad (J,) each: the action space's bounds, commands are clipped into them (the joint
        #: ranges here; a task may narrow them, :meth:`_action_bounds`).
        self.action_lower, self.action_upper = self._action_bounds()
        self.nominal_stereo = CameraPair(self.stereo.cameras)  # the baselines' calibration
        self._editor = SceneEditor(
            self.model,
            self.data,
            spec,
            self.markers.site,
            self.markers.effector,
            self.nominal_stereo,
            width,
            height,
        )
        self.perturbation = Perturbation()
        self.sensor = make_sensor(sensing, self)
        self._view = CompositeView(self.model, height, width)
        self.obs_mode = obs_mode
        self.pixels_width, self.pixels_height = pixels_size
        self._pixel_rig: PixelRig | None = None
        self._images = None
        if obs_mode != "state":
            rig = self.pixel_rig
            self._images = CameraImages(
                self.model,
                rig.views(),
                rig.height,
                rig.width,
                self.target_geom_ids,
                self.effector_geom_ids,
                rig.sphere_radius,
            )

        self._make_spaces(normalize)
        self._human: HumanViewer | None = None  # render_mode="human": the window
        if render_mode == "human":  # opens while the first reset gets ready
            self._human = self._new_viewer()
        #: Called with the simulated seconds since the move began after every physics step of a
        #: servo move (videos sample the motion with it); it may read ``data``, never write it.
        self.on_physics_step: Callable[[float], None] | None = None
        #: The settle test of a servo move, after every physics step (:func:`moving`, or its
        #: reference :func:`moving_numpy`: the same moves).
        self.moving: Callable[[np.ndarray], bool] = moving
        self._cameras_read: tuple | None = None  # the rig's cameras when last converted ...
        self._goal_points: GoalPoints | None = None  # ... to floats for the reward
        centre = np.tile([(width - 1) / 2, (height - 1) / 2], self.goal_size // 2)
        self._last = {"target": centre.copy(), "effector": centre.copy()}
        self._visible_target = np.zeros(2, dtype=bool)
        self._visible_effector = np.zeros(2, dtype=bool)
        self._detected_target = np.full(self.goal_size, np.nan)
        self._detected_effector = np.full(self.goal_size, np.nan)

    # -- Gymnasium API -------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        options = arguments.reset_options(
            options, RESET_OPTIONS, "{'keep_arm': bool, 'perturb': Perturbation | dict | None}"
        )
        change = self._checked(options["perturb"]) if "perturb" in options else None
        super().reset(seed=seed)
        if self._human is not None:
            self._human.start(self.model, self.data)
        if change is not None:
            self._apply(change)
        target, orientation = self._draw_target()
        if options.get("keep_arm", False):
            self.data.qvel[:] = 0.0
        else:
            self.restore_start()
        self.data.mocap_pos[self.target_mocap_id] = target
        if orientation is not None:
            self.data.mocap_quat[self.target_mocap_id] = orientation
        self._forward()
        self._sense_target()
        self._sense_effector()
        observation = self._observation()
        info = self._info(self._observed_reward_terms(observation), clipped=False, settle_time=0.0)
        if self.render_mode == "human":
            self.render()
        return observation, info

    def step(self, action: np.ndarray):
        self.require_reset()
        command, clipped = self._check_action(action)
        settle_time = self._move(command)
        self._sense_effector()
        observation = self._observation()
        terms = self._observed_reward_terms(observation)
        info = self._info(terms, clipped=clipped, settle_time=settle_time)
        reward = total_reward(terms)
        if self.render_mode == "human":
            self.render()
        terminated = self.terminate_on_success and info["is_success"]
        return observation, reward, terminated, False, info

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> float | np.ndarray:
        """The step reward for goals (..., G) (pixels, or normalised with ``normalize``; G = 4
        for the reach task).

        ``info``: one dict, dicts shaped like the batch (list or object array, as HER passes
        them), or None (every effector marker taken as seen). A float for one pair of goals, an
        array of the batch shape otherwise; bit-identical to the step's reward for its goals.
        """
        return total_reward(self._reward_terms(achieved_goal, desired_goal, info))

    def _goal_coordinates(
        self, achieved_goal, desired_goal
    ) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
        """(batch shape, achieved, desired): the goals' coordinates (G, *shape) px (normalised
        goals mapped back to pixels); shape ``()`` for one transition."""
        a, d = np.asarray(achieved_goal, dtype=float), np.asarray(desired_goal, dtype=float)
        size = self.goal_size
        if a.shape == d.shape == (size,):  # one transition
            shape: tuple[int, ...] = ()
        else:
            if a.shape[-1:] != (size,) or d.shape[-1:] != (size,):
                raise ValueError(
                    f"goals are (..., {size}) pixel vectors ({self._goal_layout}), got "
                    f"shapes {a.shape} and {d.shape}"
                )
            shape = np.broadcast_shapes(a.shape, d.shape)[:-1]
            a = np.moveaxis(np.broadcast_to(a, (*shape, size)), -1, 0)
            d = np.moveaxis(np.broadcast_to(d, (*shape, size)), -1, 0)
        if self.normalize:
            half = self._pixel_half[:size].reshape(size, *(1,) * len(shape))
            a, d = (a + 1.0) * half, (d + 1.0) * half
        return shape, a, d

    #: How a goal vector is laid out, for messages.
    _goal_layout = "u_left, v_left, u_right, v_right"
    #: The reward's terms, in the order they are added (``info`` keys).
    REWARD_TERMS: ClassVar[tuple[str, ...]] = ("reward_distance", "reward_unseen")

    def _reward_terms(self, achieved_goal, desired_goal, info: Any) -> tuple[Any, ...]:
        """The reward's terms (:attr:`REWARD_TERMS`) of goals as observed, ``info`` as HER
        passes it: the goals in pixels, then :meth:`_pixel_reward_terms`."""
        shape, a_q, d_q = self._goal_coordinates(achieved_goal, desired_goal)
        return self._pixel_reward_terms(a_q, d_q, seen_flags(info, shape))

    def _pixel_reward_terms(self, achieved: np.ndarray, desired: np.ndarray, seen) -> tuple:
        """(reward_distance, reward_unseen) of goals (G, *shape) px through
        :func:`envs.reward.reward_terms`; ``seen``: bool, or a bool array of the batch shape."""
        return reward_terms(self.goal_points, achieved, desired, seen, self.reach)

    @property
    def goal_points(self) -> GoalPoints:
        """The stereo rig's cameras as floats for triangulating goals, re-read when the rig
        changed (a perturbation)."""
        if self._cameras_read is not self.stereo.cameras:  # (re)read if the rig changed
            self._cameras_read = self.stereo.cameras
            cameras = tuple(camera_floats(c) for c in self.stereo.cameras)
            self._goal_points = GoalPoints(cameras, self.stereo.camera_rows)
        return self._goal_points

    def _observed_reward_terms(self, observation: dict[str, np.ndarray]) -> tuple[Any, ...]:
        """The reward's terms of the transition just observed. Its goals are the pixels the
        observation was made from, so only normalised goals are mapped back (the same bits as
        ``compute_reward`` on the observation's goals and ``info``)."""
        achieved, desired = self._last["effector"], self._last["target"]
        if self.normalize:
            _, achieved, desired = self._goal_coordinates(
                observation["achieved_goal"], observation["desired_goal"]
            )
        return self._pixel_reward_terms(achieved, desired, all(self._visible_effector.tolist()))

    def render(self) -> np.ndarray | None:
        if self.render_mode == "human":
            if self._human is None:  # closed before
                self._human = self._new_viewer()
            self._human.show(self.model, self.data)
            return None
        if self.render_mode != "rgb_array":
            return None
        return self._view.render(self.data, self._last["target"], self._detected_effector)

    @property
    def pixel_rig(self) -> PixelRig:
        """The image observations' cameras at ``pixels_height`` × ``pixels_width``
        (:class:`envs.sensing.pixel_cameras.PixelRig`), placed at the first use (with
        ``obs_mode`` "pixels" or "state_pixels": when the env is made)."""
        if self._pixel_rig is None:
            self._pixel_rig = PixelRig.frame(self, self.pixels_height, self.pixels_width)
        return self._pixel_rig

    def _action_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The action space's bounds (J,) rad each: the joint ranges."""
        return self.joint_lower.copy(), self.joint_upper.copy()

    def _task_markers(self, robot: str, joints: int) -> MarkerSet | None:
        """The task's markers for :class:`ArmScene` (None: the reach task's)."""
        return None

    def _draw_target(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The next target's world position (3,) m and orientation (a unit quaternion (4,), or
        None to leave the mocap body's), drawn with ``np_random``: a point uniform in the
        robot's workspace, moved with the base."""
        target = self.robot_spec.workspace.sample_one(self.np_random)
        return target + self.perturbation.base_shift, None

    def skip_targets(self, count: int) -> None:
        """Draw and drop the next ``count`` targets that ``reset`` would draw: ``np_random``
        ends where ``count`` resets leave it, and nothing else changes (a worker that evaluates
        trials k.. of a held-out stream starts where one evaluating them all would be)."""
        for _ in range(count):
            self._draw_target()

    def close(self) -> None:
        super().close()
        self._view.close()
        if self._images is not None:
            self._images.close()
        if self._human is not None:
            self._human.close()
            self._human = None

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
            PerturbationError: a change or a size of the wrong type or shape, not finite, too
                large, or taking the workspace out of view; nothing has changed then (the
                model, the cameras, the simulation, and ``np_random``: it draws as if the call
                had not been made).
        """
        if random is None:
            return self._apply(self._checked(change))
        if change is not None:
            raise ValueError("pass either a change or random sizes, not both")
        sizes = random_sizes(random)
        if seed is not None:
            seed = arguments.seed("seed", seed)
        rng = self.np_random if seed is None else np.random.default_rng(seed)
        state = rng.bit_generator.state
        try:
            change = self._checked(Perturbation.random(rng, **sizes))
        except PerturbationError:  # a refused change draws nothing
            rng.bit_generator.state = state
            raise
        return self._apply(change)

    def _checked(self, change: Any) -> Perturbation:
        """``change`` as a Perturbation that keeps the workspace in view; PerturbationError
        before anything changes else."""
        change = Perturbation.of(change)
        self._editor.check(change, self.robot_spec.workspace)
        return change

    def _apply(self, change: Perturbation) -> Perturbation:
        """Write a checked change into the model and let the rig re-read its cameras."""
        self._editor.apply(change)
        mujoco.mj_forward(self.model, self.data)
        self.stereo.refresh(self.data)
        self.perturbation = change
        return change

    def sensed_target(self) -> np.ndarray:
        """Target pixels (G,) sensed at the last reset (4 per marker); NaN in a camera that did
        not see a marker."""
        return self._detected_target.copy()

    def sensed_effector(self) -> np.ndarray:
        """Marker pixels (G,) sensed after the last move (4 per marker); NaN in a camera that did
        not see a marker."""
        return self._detected_effector.copy()

    def _new_viewer(self) -> HumanViewer:
        """The window of ``render_mode="human"``, framed on this robot's workspace."""
        return HumanViewer(
            self.metadata["render_fps"],
            self.robot_spec.workspace,
            self.target_geom_ids,
            self.effector_geom_ids,
        )

    @property
    def human_viewer(self) -> HumanViewer | None:
        """``render_mode="human"``: the window's viewer, once the first render opened it."""
        return self._human

    # -- internals -----------------------------------------------------------------------------

    @property
    def reach(self) -> float:
        """The robot's reach in metres, for errors in % of the robot's size."""
        return self.robot_spec.reach

    def _check_action(self, action: np.ndarray) -> tuple[np.ndarray, bool]:
        """The command (J,) rad for the controlled joints, clipped into their ranges, and
        whether it was clipped; ValueError for a wrong shape or a value that is not finite."""
        real = isinstance(action, np.ndarray) and action.dtype.char in "fd"  # float32, float64
        a = action if real else arguments.real_numbers("action", action, "real numbers (rad)")
        if a.shape != (self.joints,):
            raise ValueError(
                f"action must have shape ({self.joints},) (joint1..joint{self.joints} in rad), "
                f"got shape {a.shape}"
            )
        if pinhole_kernels.ENABLED:
            command = np.empty(self.joints)
            bad, clipped = clip_command(a, self._action_mid, self._action_half, self.action_lower,
                                        self.action_upper, self.normalize, command)  # fmt: skip
        else:
            bad, command, clipped = self._clipped_numpy(a)
        if bad >= 0:
            raise ValueError(f"action for joint{bad + 1} is {a[bad]}; commands must be finite")
        return command, clipped

    def _clipped_numpy(self, a: np.ndarray) -> tuple[int, np.ndarray, bool]:
        """:func:`envs.kernels.clip_command` on arrays: (the first joint whose action is not
        finite or -1, the command, whether the action was clipped)."""
        finite = np.isfinite(a)
        if not finite.all():
            return int(np.flatnonzero(~finite)[0]), a, False
        if self.normalize:  # [-1, 1] per joint -> its action bounds
            inside = np.minimum(np.maximum(a, -1.0), 1.0)
            command = self._action_mid + self._action_half * inside
            command = np.minimum(np.maximum(command, self.action_lower), self.action_upper)
            return -1, command, bool((inside != a).any())
        command = np.minimum(np.maximum(a, self.action_lower), self.action_upper)
        return -1, command, bool((command != a).any())

    def _forward(self) -> None:
        """Positions from qpos: kinematic control needs only the kinematics and the cameras
        (what sensing and rendering read); servo control the whole forward pass."""
        if self.control == "kinematic":
            mujoco.mj_kinematics(self.model, self.data)
            mujoco.mj_camlight(self.model, self.data)
        else:
            mujoco.mj_forward(self.model, self.data)

    def _move(self, command: np.ndarray) -> float:
        if self.control == "kinematic":
            self.set_joints(command)
            return 0.0
        self.data.ctrl[self._ctrl] = command
        start = self.data.time
        slow_since = None  # s, when every joint last became slower than SETTLE_SPEED
        on_step = self.on_physics_step
        moving, qvel = self.moving, self.data.qvel  # qvel: a view, updated by every step
        steps = 0
        while True:
            mujoco.mj_step(self.model, self.data)
            steps += 1
            elapsed = self.data.time - start
            if on_step is not None:
                on_step(elapsed)
            if moving(qvel):
                slow_since = None
            elif slow_since is None:
                slow_since = elapsed
            settled = slow_since is not None and elapsed - slow_since >= SETTLE_WINDOW
            if (elapsed >= MIN_SETTLE_TIME and settled) or elapsed >= MAX_SETTLE_TIME:
                self.physics_steps += steps
                return float(elapsed)

    def _sense_target(self) -> None:
        pixels, visible = self.sensor.sense_target(self.data)
        self._visible_target = self._per_camera(visible)
        self._detected_target = pixels
        self._remember("target", pixels, visible)

    def _sense_effector(self) -> None:
        # The markers are expected where the target's are: that is where a reach aims.
        if self.sensing != "project" and self._effector_out_of_view():
            pixels = np.full(self.goal_size, np.nan)  # what rendering would find: nothing
            visible = np.zeros(self.goal_size // 2, dtype=bool)
        else:
            pixels, visible = self.sensor.sense_effector(self.data, self._detected_target)
        self._visible_effector = self._per_camera(visible)
        self._detected_effector = pixels
        self._remember("effector", pixels, visible)

    def _effector_out_of_view(self) -> bool:
        """Whether every marker sphere on the arm lies wholly outside both cameras' images (or
        behind them), by more than OUT_OF_VIEW_PX: rendering could not see any of it, so it is
        not rendered (the grasp task's parked arm at every reset)."""
        centres = self.data.geom_xpos[self.effector_geom_ids]  # (M, 3)
        size = np.array([self.image_width - 1.0, self.image_height - 1.0])
        for camera in self.stereo.cameras:
            depth = (camera.position - centres) @ camera.rotation[:, 2]  # (M,) along the view
            ahead = depth > self.marker_radius
            if not ahead.any():
                continue
            uv = camera.project(centres[ahead])
            reach = camera.sphere_semi_axes(centres[ahead], self.marker_radius)[:, :1]
            reach = reach + OUT_OF_VIEW_PX
            inside = np.all((uv + reach >= 0.0) & (uv - reach <= size), axis=1)
            if inside.any():
                return False
        return True

    @staticmethod
    def _per_camera(visible: np.ndarray) -> np.ndarray:
        """(2,) bool: each camera saw every marker (``visible`` (2M,): per marker, per camera)."""
        return visible if len(visible) == 2 else visible.reshape(-1, 2).all(axis=0)

    def _remember(self, marker: str, pixels: np.ndarray, visible: np.ndarray) -> None:
        """Keep each sighting by both cameras as that marker's goal, inside the image: a
        projected centre is inside by the visibility test; a rendered one may be shifted out by
        the sub-pixel perspective correction and is clipped. A marker not seen by both keeps
        its last sighting."""
        flags = visible.tolist()
        if all(flags):  # every marker seen (the reach task's one marker: the only case)
            if self.sensor.may_leave_image:
                pixels = np.minimum(np.maximum(pixels, 0.0), self._pixel_max[: self.goal_size])
            self._last[marker] = pixels
            return
        kept = self._last[marker].copy()
        for k in range(0, len(flags), 2):  # k / 2: the marker
            if flags[k] and flags[k + 1]:
                seen = pixels[2 * k : 2 * k + 4]
                if self.sensor.may_leave_image:
                    seen = np.minimum(np.maximum(seen, 0.0), self._pixel_max[:4])
                kept[2 * k : 2 * k + 4] = seen
        self._last[marker] = kept

    def _observation(self) -> dict[str, np.ndarray]:
        # Servo moves overshoot a commanded limit by up to ~1e-4 rad: clipped into the space.
        # Kinematic moves set the clipped command (reset: the in-range keyframe).
        lo, hi = np.maximum, np.minimum
        joints = self.data.qpos[self._qpos]
        if self.control == "kinematic":
            joints = joints.copy()
        else:
            joints = hi(lo(joints, self.joint_lower), self.joint_upper)
        achieved, desired = self._last["effector"], self._last["target"]  # (G,) px, in the image
        if not self.normalize:
            obs = {
                "observation": joints,
                "achieved_goal": achieved.copy(),
                "desired_goal": desired.copy(),
            }
        else:
            joints = hi(lo((joints - self._joint_mid) / self._joint_half, -1.0), 1.0)
            goals = np.concatenate((achieved, desired))  # (2G,) px
            goals = hi(lo(goals / self._pixel_half - 1.0, -1.0), 1.0)
            size = self.goal_size
            obs = {
                "observation": joints,
                "achieved_goal": goals[:size],
                "desired_goal": goals[size:],
            }
        if self._images is None:
            return obs
        obs.update(zip(PIXEL_KEYS, self._images.render(self.data), strict=True))
        return {key: obs[key] for key in OBS_MODES[self.obs_mode]}

    def _make_spaces(self, normalize: bool) -> None:
        """Bounded spaces: joints by their ranges, goals by the image (or [-1, 1] each)."""
        self.normalize = bool(normalize)
        self._joint_mid = (self.joint_upper + self.joint_lower) / 2  # rad
        self._joint_half = (self.joint_upper - self.joint_lower) / 2  # rad
        self._action_mid = (self.action_upper + self.action_lower) / 2  # rad
        self._action_half = (self.action_upper - self.action_lower) / 2  # rad
        size = self.goal_size
        self._pixel_max = np.tile([self.image_width - 1.0, self.image_height - 1.0], size)  # (2G,)
        self._pixel_half = self._pixel_max / 2  # px
        box = gym.spaces.Box
        if self.normalize:  # float32 actions, as Stable-Baselines3 recommends
            self.action_space = box(-1.0, 1.0, (self.joints,), dtype=np.float32)
            joints = box(-1.0, 1.0, (self.joints,), dtype=np.float64)
            pixels = box(-1.0, 1.0, (size,), dtype=np.float64)
        else:
            joints = box(self.joint_lower, self.joint_upper, dtype=np.float64)
            pixels = box(np.zeros(size), self._pixel_max[:size], dtype=np.float64)
            self.action_space = box(self.action_lower, self.action_upper, dtype=np.float64)
        image = box(0, 255, (self.pixels_height, self.pixels_width, 3), dtype=np.uint8)
        spaces = {
            "observation": joints,
            "pixels_left": image,
            "pixels_right": image,
            "achieved_goal": pixels,
            "desired_goal": pixels,
        }
        self.observation_space = gym.spaces.Dict({k: spaces[k] for k in OBS_MODES[self.obs_mode]})

    def _info(self, reward_terms: tuple[Any, ...], clipped: bool, settle_time: float) -> StepInfo:
        """The transition's ``info``; ``reward_terms`` in :attr:`REWARD_TERMS`' order, whose
        first is the distance's and last the unseen marker's (a task adds the others)."""
        target = self.data.mocap_pos[self.target_mocap_id].copy()
        effector = self.sensed_point()
        distance = math.dist(target.tolist(), effector.tolist())
        achieved, desired = self._last["effector"].tolist(), self._last["target"].tolist()
        image_errors = [  # px, per camera and marker
            math.hypot(achieved[k] - desired[k], achieved[k + 1] - desired[k + 1])
            for k in range(0, len(achieved), 2)
        ]
        return StepInfo(
            distance=distance,
            pixel_error=sum(image_errors) / len(image_errors),
            is_success=distance < self.success_threshold,
            visible=all(self._visible_target.tolist() + self._visible_effector.tolist()),
            visible_target=self._visible_target.copy(),
            visible_effector=self._visible_effector.copy(),
            target_pos=target,
            effector_pos=effector,
            clipped=clipped,
            settle_time=settle_time,
            reward_distance=reward_terms[0],
            reward_unseen=reward_terms[-1],
        )
