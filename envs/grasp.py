"""GraspEnv: bring an arm's hand to an object's position and orientation, seen by two cameras."""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from envs import arguments
from envs.pose_reward import pose_reward_terms
from envs.reach import PIXELS_HEIGHT, PIXELS_WIDTH, SUCCESS_THRESHOLD, ReachEnv
from envs.robots import MarkerSet, grasp_env_ids, robot_spec
from envs.scene import IMAGE_HEIGHT, IMAGE_WIDTH
from envs.sensing.rendering import GROUP_MARKER, GROUP_ROBOT
from envs.step_info import StepInfo
from models.grasp_task import GraspTask
from models.marker_frame import marker_points, orientation_angle
from models.puma560.grasp import OrientationRange
from models.workspace import BoxWorkspace

#: The Gymnasium ids of the grasp envs: every robot's of the registry (envs/robots.py).
GRASP_ENV_IDS = grasp_env_ids()
#: The geom groups that may hide the object from a camera: the robot and its markers.
ROBOT_GROUPS = np.array([int(g in (GROUP_ROBOT, GROUP_MARKER)) for g in range(6)], dtype=np.uint8)
#: px: the least gap between two of the hand's marker images at the grasp (an object whose
#: marker frame a camera sees edge-on, two markers one behind the other, is drawn again).
MARKER_GAP_PX = 1.0
#: The ``action_range`` choices: the task's joint box or the joint ranges.
ACTION_RANGES = ("task", "joints")
#: rad: success needs the hand's orientation within this angle of the object's (5°).
ORIENTATION_THRESHOLD = math.radians(5.0)
#: m/rad: the orientation term's weight. The markers sit 80-140 mm from the frame's origin, so
#: an orientation error of θ moves them by about 0.1·θ m: with this weight both terms measure
#: how far the markers are from where they should be, in metres, and neither swamps the other
#: (1° costs 1.7 mm; the 5° success bound 8.7 mm against the 5 mm of the position).
ORIENTATION_WEIGHT = 0.1


class GraspEnv(ReachEnv):
    """Bring an arm's hand to an object's pose, seen only through two cameras.

    Every robot of the registry whose model offers the pose task (``MODEL.grasp``,
    :class:`~models.grasp_task.GraspTask`) has a grasp env: ``PumaGrasp-v0`` (below) and
    ``Ur5eGrasp-v0``, an arm generated from a DH table with a ``[grasp]`` section (its hand
    carries the same three markers at its tcp, without a gripper; its objects are the hand's
    poses at joints drawn uniformly from its task's joint box, ``models.dh_grasp``; all its
    joints are commanded, the box is the action space, the arm starts at ``home``, and it takes
    no ``orientations``). The robot is ``robot``, set by the id.

    ``PumaGrasp-v0``: the PUMA 560 carries a two-finger gripper with three marker spheres
    (yellow, cyan, magenta, 24 mm: ``models.puma560.grasp.MARKER_OFFSETS`` in the tool frame of
    site ``tcp``). The object to grasp is a mocap body carrying three markers at the same
    offsets in its own frame (red, green, blue, 20 mm; and a handle the cameras' colour sensing
    ignores): the hand grasps it when the two frames coincide, and then every hand marker
    encloses the object's marker of its pair. All six joints are commanded. The machinery
    (moves, sensing modes, perturbations, viewer, rendering, spaces) is
    :class:`envs.reach.ReachEnv`'s; only the target and the reward differ.

    ## Action space
    ``Box(action_lower, action_upper, (6,), float64)``: absolute command in radians for
    ``joint1``..``joint6``, as ``PumaReach-v0`` with ``joints=6`` (clipped into the box,
    ``info["clipped"]``; NaN, inf, a wrong shape or a non-number raise ``ValueError``). With
    ``action_range="task"`` (the default) the box is the task's joint box
    (:func:`~models.puma560.grasp.task_joint_box`): the smallest box of the joints that grasp
    4 096 of the range's objects; a uniformly random action there leaves the hand in both
    cameras' rendered views 73 % of the time (27 % over the whole joint ranges). An object whose
    grasping joints fall outside it (1 in 290) is drawn again, so the exact grasp
    is always an action. ``action_range="joints"``: the joint ranges.

    ## Observation space
    ``Dict`` in the Gymnasium-Robotics goal convention:

    | key | shape | unit | meaning |
    |---|---|---|---|
    | ``observation`` | (6,) | rad | joint angles |
    | ``achieved_goal`` | (12,) | px | the hand's markers: (u_left, v_left, u_right, v_right) each |
    | ``desired_goal`` | (12,) | px | the object's markers, same layout |
    | ``pixels_left``, ``pixels_right`` | (H, W, 3) uint8 | | camera images (``obs_mode``) |

    Markers in pair order (the object's red, green, blue; the hand's yellow, cyan, magenta);
    pixels of the 320×240 sensing images (``width`` × ``height``), each bounded by the image.
    The cameras see the object and the robot together, as a camera on a real robot would: the
    object's markers are sensed at reset (the arm parked out of their way) and the hand's after
    every move, each in images of the whole scene (the arm, the hand or the object may hide a
    marker; a partly hidden one is fitted from its visible outline). The object does not move
    in an episode, so its sighting at reset is kept; at the grasp the hand's larger markers
    hide it anyway. A marker not seen by both cameras keeps its last valid sensing (before any,
    the image centre). ``normalize`` and ``obs_mode`` act as in ``ReachEnv``.

    ## Reward
    ``reward = reward_distance + reward_orientation + reward_unseen``, computed from the goals
    alone (``envs.pose_reward``), so ``reward == compute_reward(achieved_goal, desired_goal,
    info)`` bit for bit, for batches too, and relabelling (HER) works:

    - ``reward_distance``: minus the distance (m) between the frames' origins found from the
      triangulated markers (least-squares rigid fit, ``pose_from_points``).
    - ``reward_orientation``: minus ``ORIENTATION_WEIGHT`` (0.1 m/rad) times the angle between
      the two fitted orientations (rad).
    - ``reward_unseen``: minus the PUMA's reach (0.86 m) when some hand marker was not seen by
      both cameras after the move (``info["visible_effector"]``), else 0. With the default
      action box a random action keeps the hand in both rendered views 73 % of the time.

    Success is judged on the ground truth: ``info["is_success"]`` is ``distance <
    success_threshold`` and ``orientation_error < orientation_threshold``.

    ## Starting state
    ``reset`` draws the object's pose with ``self.np_random``
    (``models.puma560.grasp.sample_grasp_pose``): the wrist centre uniform in the reach task's
    workspace box, the orientation from ``orientations`` (by default turned up to ±90° about the
    vertical and its approach tilted up to 45° from it), drawn again until the right-arm,
    elbow-above configuration of the exact pose IK has every joint in range with ``ready``'s
    wrist flip or the other (those joints are :attr:`target_joints`, inside the action box),
    the images of the object's three marker spheres lie wholly inside both cameras' images, the
    images of the hand's markers at the grasp are :data:`MARKER_GAP_PX` apart in both (not one
    behind the other), and the robot where the episode starts hides no marker's centre. The arm
    returns to the keyframe ``park`` (raised, out of the cameras' way) unless
    ``reset(options={"keep_arm": True})``;
    ``reset(options={"perturb": change})`` as in ``ReachEnv`` (a tool change moves the hand's
    three markers along the tool axis).

    ## Episode end
    Never terminates unless ``terminate_on_success`` (as in ``ReachEnv``: at the first move whose
    ``is_success`` holds); truncated after ``max_episode_steps`` moves (registered default 4).

    ## Info
    Everything ``ReachEnv`` gives, over all three markers: ``distance`` (m, ground truth, tool
    point to the object's origin), ``pixel_error`` (px, mean over markers and cameras),
    ``visible``, ``visible_target`` and ``visible_effector`` ((2,) bool per camera: all three
    markers seen by it), ``target_pos``, ``effector_pos``, ``clipped``, ``settle_time``,
    ``is_success``; and ``orientation_error`` (rad, ground truth angle between the hand's and
    the object's orientations), ``target_pose`` and ``effector_pose`` ((4, 4) world poses of the
    object and of the tool frame), ``reward_distance``, ``reward_orientation``,
    ``reward_unseen``.

    ## Arguments
    - ``robot`` (``"puma560"``): the registry's robot (set by the id); a robot without a pose
      task is refused with one line.
    - ``sensing`` (``"render"``): ``"render"``, ``"project"`` or ``"foveated"``, as in
      ``ReachEnv``; each marker is sensed like the reach task's one (foveated: the hand's
      markers in windows about the object's markers of their pairs).
    - ``control`` (``"servo"``): ``"servo"`` or ``"kinematic"``, as in ``ReachEnv``.
    - ``orientations`` (None): the range of the objects' orientations, None for the robot's
      default (the PUMA's ``"yaw:90,tilt:45"``; none for a generated arm), an
      :class:`~models.puma560.grasp.OrientationRange` or its spelling: ``"yaw:Y,tilt:T"``
      (degrees; the hand upright, turned by up to ±Y about the vertical, its approach tilted by
      up to T from it; Y ≤ 180, T ≤ 80) or ``"ball:A"`` (within A of the hand's orientation at
      ``ready`` about any axis; ``"ball:30"`` is the first releases' range).
    - ``action_range`` (``"task"``): ``"task"`` or ``"joints"`` (the action space above).
    - ``success_threshold`` (0.005): metres.
    - ``orientation_threshold`` (0.08726646259971647): radians (5°).
    - ``width`` (320): width of the sensing images in pixels.
    - ``height`` (240): their height (4:3).
    - ``render_mode`` (None): ``"rgb_array"`` (both views and the overview, each object marker
      crosshaired and each detected hand marker circled) or ``"human"``.
    - ``obs_mode`` (``"state"``): ``"state"``, ``"pixels"`` or ``"state_pixels"``.
    - ``pixels_width`` (84): width of each camera image of the pixel modes.
    - ``pixels_height`` (84): their height.
    - ``normalize`` (False): action, joints and goals in [-1, 1].
    - ``terminate_on_success`` (False): end the episode at the first successful move.
    """

    REWARD_TERMS = ("reward_distance", "reward_orientation", "reward_unseen")
    _goal_layout = "u_left, v_left, u_right, v_right of the red, green and blue markers"

    def __init__(
        self,
        robot: str = "puma560",
        sensing: str = "render",
        control: str = "servo",
        orientations: str | OrientationRange | None = None,
        action_range: str = "task",
        success_threshold: float = SUCCESS_THRESHOLD,
        orientation_threshold: float = ORIENTATION_THRESHOLD,
        width: int = IMAGE_WIDTH,
        height: int = IMAGE_HEIGHT,
        render_mode: str | None = None,
        obs_mode: str = "state",
        pixels_width: int = PIXELS_WIDTH,
        pixels_height: int = PIXELS_HEIGHT,
        normalize: bool = False,
        terminate_on_success: bool = False,
    ) -> None:
        threshold = arguments.positive_number("orientation_threshold (rad)", orientation_threshold)
        spec = robot_spec(robot)
        if spec.grasp is None or spec.kinematics.grasp is None:
            valid = ", ".join(grasp_env_ids())
            raise ValueError(
                f"robot {spec.model!r} has no grasp task (no grasp markers in its registry "
                f"entry and no MODEL.grasp); the grasp envs: {valid}"
            )
        #: The arm's pose task: kinematics, pose IK, object poses, joint box.
        self.task: GraspTask = spec.kinematics.grasp
        #: The range the objects' orientations are drawn from (None: the arm's joint box).
        self.orientations = self.task.orientations(orientations)
        if not isinstance(action_range, str) or action_range not in ACTION_RANGES:
            raise ValueError(
                f"unknown action_range {action_range!r}; valid: {', '.join(ACTION_RANGES)}"
            )
        self.action_range = action_range
        super().__init__(
            robot=robot,
            joints=self.task.n_joints,
            sensing=sensing,
            control=control,
            success_threshold=success_threshold,
            width=width,
            height=height,
            render_mode=render_mode,
            normalize=normalize,
            obs_mode=obs_mode,
            pixels_width=pixels_width,
            pixels_height=pixels_height,
            terminate_on_success=terminate_on_success,
        )
        self.orientation_threshold = threshold
        self._object = self.model.body(self.markers.target_body).id
        self._probe = mujoco.MjData(self.model)  # the arm where an episode starts, for _hidden
        self._keep_arm = False  # the episode being reset starts where the last one ended
        self._cameras = [self.model.camera(name).id for name in self.stereo.camera_names]
        self._geom = np.zeros(1, dtype=np.int32)  # mj_ray's output: the geom hit
        #: The exact IK joints (J,) rad that grasp the current object (ground truth, for
        #: evaluation and tests; a learner does not see them).
        self.target_joints = np.full(self.task.n_joints, np.nan)

    def learner_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The joint ranges (J,), (J,) rad a learner of this task is given: the action box if
        the task's markers ask for it (``MarkerSet.learn_in_action_box``), else the joint
        ranges."""
        if self.markers.learn_in_action_box:
            return self.action_lower.copy(), self.action_upper.copy()
        return self.joint_lower.copy(), self.joint_upper.copy()

    def _action_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The task's joint box (``action_range="task"``) or the joint ranges."""
        if self.action_range == "joints":
            return super()._action_bounds()
        return self.task.joint_box(self.orientations)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self._keep_arm = isinstance(options, dict) and options.get("keep_arm") is True
        return super().reset(seed=seed, options=options)

    def _task_markers(self, robot: str, joints: int) -> MarkerSet | None:
        return robot_spec(robot).grasp

    def _draw_target(self) -> tuple[np.ndarray, np.ndarray | None]:
        """The object's position (3,) m and orientation quaternion (4,), from the task's
        ``sample`` (the PUMA's :func:`~models.puma560.grasp.sample_grasp_pose`) in the
        (shifted) workspace box."""
        shift = self.perturbation.base_shift
        box = self.robot_spec.workspace
        box = BoxWorkspace(box.lower + shift, box.upper + shift)
        probe = self._probe  # the arm where the episode starts, once for every draw
        probe.qpos[:] = self.data.qpos if self._keep_arm else self.model.key_qpos[self._home]
        mujoco.mj_kinematics(self.model, probe)
        mujoco.mj_camlight(self.model, probe)
        while True:
            pose, self.target_joints = self.task.sample(
                self.np_random, box, self.task.base + shift, self.orientations
            )
            inside = np.all(self.target_joints >= self.action_lower) and np.all(
                self.target_joints <= self.action_upper
            )  # the exact grasp is an action
            points = marker_points(pose)
            if inside and self._in_view(points) and not self._hidden(points):
                break
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, pose[:3, :3].ravel())
        return pose[:3, 3], quat

    def _in_view(self, points: np.ndarray) -> bool:
        """Whether the images of the marker spheres at ``points`` (3, 3) lie wholly inside both
        cameras' images, and the images of the hand's (larger) markers there, at the grasp,
        stay :data:`MARKER_GAP_PX` apart in both (the object is a task only if the cameras can
        see all of it, and tell the hand's markers apart when it holds it)."""
        size = np.array([self.image_width - 1.0, self.image_height - 1.0])
        for camera in self.stereo.cameras:
            uv = camera.project(points)  # (3, 2) px
            margin = camera.sphere_semi_axes(points, self.target_radius)[:, :1]  # (3, 1) px
            if np.any(uv - margin < 0.0) or np.any(uv + margin > size):
                return False
            hand = camera.sphere_semi_axes(points, self.marker_radius)[:, 0]  # (3,) px
            for a, b in ((0, 1), (0, 2), (1, 2)):
                if np.linalg.norm(uv[a] - uv[b]) < hand[a] + hand[b] + MARKER_GAP_PX:
                    return False
        return True

    def _hidden(self, points: np.ndarray) -> bool:
        """Whether the robot, where the episode starts (``park``, or where the last one ended
        with ``keep_arm``), stands between a camera and the centre of a marker at ``points``
        (3, 3) (MuJoCo's ray casting against the robot's and its markers' geoms, with the arm
        of ``_probe``, which :meth:`_draw_target` places)."""
        probe, geom = self._probe, self._geom
        for camera in self._cameras:
            origin = probe.cam_xpos[camera]
            for point in points:
                ray = point - origin
                length = float(np.linalg.norm(ray))
                hit = mujoco.mj_ray(
                    self.model, probe, origin, ray / length, ROBOT_GROUPS, 1, -1, geom
                )
                if 0.0 <= hit < length - self.target_radius:
                    return True
        return False

    def _pixel_reward_terms(self, achieved: np.ndarray, desired: np.ndarray, seen) -> tuple:
        """(reward_distance, reward_orientation, reward_unseen) through
        :func:`envs.pose_reward.pose_reward_terms`."""
        cameras = self.goal_points.cameras
        return pose_reward_terms(cameras, achieved, desired, seen, self.reach, ORIENTATION_WEIGHT)

    def target_pose(self) -> np.ndarray:
        """World pose (4, 4) of the object (ground truth)."""
        pose = np.eye(4)
        pose[:3, :3] = self.data.xmat[self._object].reshape(3, 3)
        pose[:3, 3] = self.data.xpos[self._object]
        return pose

    def effector_pose(self) -> np.ndarray:
        """World pose (4, 4) of the hand's tool frame, site ``tcp`` (ground truth)."""
        pose = np.eye(4)
        pose[:3, :3] = self.data.site_xmat[self.sensed_site_id].reshape(3, 3)
        pose[:3, 3] = self.data.site_xpos[self.sensed_site_id]
        return pose

    def _info(self, reward_terms: tuple[Any, ...], clipped: bool, settle_time: float) -> StepInfo:
        info = super()._info(reward_terms, clipped, settle_time)
        info["reward_orientation"] = reward_terms[1]
        target, effector = self.target_pose(), self.effector_pose()
        error = float(orientation_angle(effector[:3, :3], target[:3, :3]))
        info["orientation_error"] = error
        info["target_pose"], info["effector_pose"] = target, effector
        info["is_success"] = info["is_success"] and error < self.orientation_threshold
        return info
