"""A Menagerie-style robot folder from a DH table: ``<robot>.xml`` (capsule links, position
actuators ``joint1``..``jointN``, sites ``base`` and ``tcp``, the green marker, keyframes ``home``
and ``ready``), ``scene.xml`` (floor, light, the stereo pair ``cam_left``/``cam_right`` placed so
that the reachable workspace fills both images, ``overview``, the mocap ``target``), ``README.md``,
the table file itself and the package's ``__init__.py`` (its ``MODEL``).

The cameras: tcp positions of joint vectors drawn uniformly from the ranges (seeded) are framed by
two cameras side by side, aimed at the points' centre from the side of the target box, far enough
that every point lies in front of both, with a vertical field of view that leaves ``margin`` of
the image free around them (:func:`place_cameras`).
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from models.dh_arm import (
    WORKSPACE_SAMPLES,
    DHArm,
    Factor,
    arm_kinematics,
    base_transform,
    elementary,
    fixed_factors,
    fixed_transforms,
    joint_frames,
    reach,
    sample_reachable,
)
from models.marker_frame import HAND_COLOURS, MARKER_COLOURS, MARKER_OFFSETS

CAMERA_ASPECT = 4 / 3  # width / height of the sensing images (320 x 240)
CAMERA_MARGIN = 0.15  # the sampled workspace spans this much less than the image's half-size
CAMERA_ELEVATION = math.radians(15.0)  # the pair looks down this much (sees under a wrist)
CAMERA_DISTANCE = 2.6  # x the workspace's radius about its centre
CAMERA_BASELINE = 0.3  # x the cameras' distance from the centre
CAMERA_SEED = 0
ARMATURE = 0.1  # kg m², rotor inertia at every joint (keeps the light wrist joints stable)
DAMPING = 1.0  # N m s/rad, joint damping
#: rad/s: each position servo's natural frequency at the joint's largest inertia
#: (:func:`servo_inertia`; kp = I ω², kv = 2 I ω: critically damped), as the PUMA's servos.
SERVO_FREQUENCY = 30.0
LINK_RGBA = "0.82 0.82 0.8 1"
#: The pose task's markers' colours (the hand's and the object's, as the PUMA's scene has them).
MARKER_RGBA = {
    "yellow": "0.9 0.9 0.1 1", "cyan": "0.1 0.9 0.9 1", "magenta": "0.9 0.1 0.9 1",
    "red": "0.9 0.1 0.1 1", "green": "0.1 0.9 0.1 1", "blue": "0.1 0.1 0.9 1",
}  # fmt: skip
HAND_MARKER_RADIUS = 0.024  # m: a fifth larger than the object's, which it encloses at the grasp
OBJECT_MARKER_RADIUS = 0.02  # m
POST_RADIUS = 0.004  # m: the marker frame's crossbar and post
#: The pose task's default classes in ``<robot>.xml`` (an arm whose table has ``[grasp]``).
HAND_DEFAULTS = [
    '      <default class="post">',
    f'        <geom group="2" type="capsule" size="{POST_RADIUS}" contype="0" conaffinity="0" '
    'mass="0" rgba="0.5 0.5 0.5 1"/>',
    "      </default>",
    '      <default class="hand_marker">',
    f'        <geom group="4" type="sphere" size="{HAND_MARKER_RADIUS}" contype="0" '
    'conaffinity="0" mass="0"/>',
    "      </default>",
]
JOINT_RGBA = "0.25 0.25 0.28 1"


@dataclass(frozen=True)
class Camera:
    """A fixed camera: position (world, m), image right and up (unit), vertical field of view
    (degrees, as MJCF takes it)."""

    name: str
    pos: np.ndarray
    right: np.ndarray
    up: np.ndarray
    fovy_deg: float

    def mjcf(self) -> str:
        xyaxes = " ".join(_f(v) for v in (*self.right, *self.up))
        return (
            f'<camera name="{self.name}" pos="{_vec(self.pos)}" fovy="{_f(self.fovy_deg)}" '
            f'xyaxes="{xyaxes}"/>'
        )


def _f(value: float) -> str:
    return f"{float(value):.10g}" if abs(value) > 1e-15 else "0"


def _vec(values) -> str:
    return " ".join(_f(v) for v in values)


def _quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method)."""
    w = math.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2
    y = math.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2
    z = math.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2
    x = math.copysign(x, R[2, 1] - R[1, 2])
    y = math.copysign(y, R[0, 2] - R[2, 0])
    z = math.copysign(z, R[1, 0] - R[0, 1])
    q = np.array([w, x, y, z])
    return q / np.linalg.norm(q)


def _pose(T: np.ndarray) -> str:
    return f'pos="{_vec(T[:3, 3])}" quat="{_vec(_quat(T[:3, :3]))}"'


def _look(eye: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Image right and up of a camera at ``eye`` looking at ``centre``, the horizon level."""
    forward = (centre - eye) / np.linalg.norm(centre - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    return right, np.cross(right, forward)


def fovy_to_fit(eye: np.ndarray, right: np.ndarray, up: np.ndarray, points: np.ndarray,
                margin: float, aspect: float = CAMERA_ASPECT) -> float:  # fmt: skip
    """Vertical field of view (rad) in which every point lies ``margin`` inside the image."""
    rel = points - eye
    depth = rel @ np.cross(up, right)  # along the viewing direction (camera -z)
    if np.any(depth <= 0):
        raise ValueError("a workspace point is behind the camera; place it farther away")
    half = np.max(np.maximum(np.abs(rel @ up), np.abs(rel @ right) / aspect) / depth)
    return 2 * math.atan(half / (1 - margin))


def place_cameras(points: np.ndarray, towards: np.ndarray, margin: float = CAMERA_MARGIN
                  ) -> tuple[Camera, Camera, Camera]:  # fmt: skip
    """``cam_left``, ``cam_right`` and ``overview`` for workspace points (N, 3).

    Args:
        towards: a point (3,) whose side the cameras stand on (the target box's centre).
    """
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    radius = float(np.max(np.linalg.norm(points - centre, axis=-1)))
    side = np.array([towards[0] - centre[0], towards[1] - centre[1]])
    side = side / np.linalg.norm(side) if np.linalg.norm(side) > 1e-6 else np.array([1.0, 0.0])
    distance = CAMERA_DISTANCE * radius
    back = np.array([*(side * math.cos(CAMERA_ELEVATION)), math.sin(CAMERA_ELEVATION)])
    stereo = frame_pair(points, back, margin)
    turn = math.radians(40.0)  # the overview looks from 40° aside of the pair, a bit higher
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    over_side = rot @ side
    eye = centre + distance * np.array([*(over_side * 0.8), 0.6])
    right, up = _look(eye, centre)
    overview = Camera(
        "overview", eye, right, up, math.degrees(fovy_to_fit(eye, right, up, points, 0.05))
    )
    return stereo[0], stereo[1], overview


def frame_pair(points: np.ndarray, back: np.ndarray, margin: float = CAMERA_MARGIN,
               aspect: float = CAMERA_ASPECT) -> tuple[Camera, Camera]:  # fmt: skip
    """``cam_left`` and ``cam_right`` side by side that frame points (N, 3): aimed at the
    points' centre from the unit direction ``back`` (from the centre towards the cameras),
    CAMERA_DISTANCE radii away, CAMERA_BASELINE of that apart, with the vertical field of view
    that leaves ``margin`` of an image of width / height ``aspect`` free around the points."""
    centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    radius = float(np.max(np.linalg.norm(points - centre, axis=-1)))
    distance = CAMERA_DISTANCE * radius
    middle = centre + distance * back
    across = np.cross([0.0, 0.0, 1.0], back)
    across /= np.linalg.norm(across)
    cameras = []
    for name, sign in (("cam_left", -1.0), ("cam_right", 1.0)):  # left: seen from the camera
        eye = middle + sign * 0.5 * CAMERA_BASELINE * distance * across
        right, up = _look(eye, centre)
        cameras.append((name, eye, right, up))
    fovy = max(fovy_to_fit(e, r, u, points, margin, aspect) for _, e, r, u in cameras)
    left, right_ = (Camera(n, e, r, u, math.degrees(fovy)) for n, e, r, u in cameras)
    return left, right_


# -- the robot -----------------------------------------------------------------------------------


def _segments(factors: list[Factor]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The straight pieces (from, to) that a fixed transform's shifts trace, in its first
    frame's coordinates (a shift of zero length traces none)."""
    T, pieces = np.eye(4), []
    for kind, value in factors:
        after = T @ elementary(kind, value)
        if kind in ("tx", "tz") and abs(value) > 1e-12:
            pieces.append((T[:3, 3].copy(), after[:3, 3].copy()))
        T = after
    return pieces


def _link_geoms(
    factors: list[Factor],
    radius: float,
    shorten_last: float = 0.0,
    origin: np.ndarray | None = None,
) -> list[str]:
    """Capsules along a fixed transform's shifts (the last one ``shorten_last`` shorter, so that
    the marker at its end stays visible), moved by ``origin`` (3,)."""
    lines = []
    shift = np.zeros(3) if origin is None else origin
    pieces = [(start + shift, end + shift) for start, end in _segments(factors)]
    for k, (start, end) in enumerate(pieces):
        if k == len(pieces) - 1 and shorten_last > 0:
            length = float(np.linalg.norm(end - start))
            if length <= shorten_last:
                continue
            end = start + (end - start) * (1 - shorten_last / length)
        lines.append(f'<geom fromto="{_vec(start)} {_vec(end)}" size="{_f(radius)}"/>')
    return lines


def mass_diagonal(model, qpos: np.ndarray) -> np.ndarray:
    """The diagonal (nv,) of MuJoCo's joint-space mass matrix at ``qpos``: each joint's
    effective inertia (kg m² for a hinge), armature included."""
    import mujoco

    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    return np.diag(full).copy()


def servo_inertia(arm: DHArm) -> np.ndarray:
    """Each joint's largest effective inertia (kg m²) at home, ready and the table's zero pose
    (clipped into range; a stretched arm for most tables), of the arm as written without servo
    gains (:func:`mass_diagonal`)."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(robot_xml(arm, np.ones(arm.n)))
    poses = (arm.home, ready_pose(arm), np.clip(0.0, arm.lower, arm.upper))
    return np.max([mass_diagonal(model, pose) for pose in poses], axis=0)


def robot_xml(arm: DHArm, inertia: np.ndarray | None = None) -> str:
    """``<robot>.xml``: the arm alone.

    Args:
        inertia: each joint's inertia for its servo's gains (kg m², :func:`servo_inertia`).
    """
    if inertia is None:
        inertia = servo_inertia(arm)
    F = fixed_transforms(arm)
    factors = fixed_factors(arm)
    B = base_transform(arm)
    cls = arm.name
    ready = ready_pose(arm)
    out = [
        f"<!-- {arm.title}: generated from its {arm.convention} DH table by "
        "visuomotor-make-arm (models/dh_mjcf.py). Body link<i> turns about its z by joint<i>; "
        "qpos equals the table's θ minus its offset. Sources: README.md. -->",
        f'<mujoco model="{arm.name}">',
        '  <compiler angle="radian" autolimits="true"/>',
        '  <option integrator="implicitfast" timestep="0.002"/>',
        "  <default>",
        f'    <default class="{cls}">',
        f'      <joint axis="0 0 1" armature="{_f(ARMATURE)}" damping="{_f(DAMPING)}"/>',
        '      <position inheritrange="1"/>',
        '      <default class="visual">',
        f'        <geom group="2" contype="0" conaffinity="0" type="capsule" rgba="{LINK_RGBA}"/>',
        '        <default class="housing">',
        f'          <geom type="cylinder" rgba="{JOINT_RGBA}"/>',
        "        </default>",
        "      </default>",
        '      <default class="marker">',
        f'        <geom group="4" type="sphere" size="{_f(arm.marker_radius)}" contype="0" '
        'conaffinity="0" rgba="0.1 0.9 0.1 1"/>',
        "      </default>",
        *(HAND_DEFAULTS if arm.grasp_box is not None else []),
        "    </default>",
        "  </default>",
        "  <worldbody>",
        '    <body name="pedestal" childclass="visual">',
    ]
    indent = "      "
    h = arm.base_height
    if h > 0:
        r = 1.2 * float(arm.radius[0])
        out.append(f'{indent}<geom class="visual" type="cylinder" size="{_f(r)} {_f(h / 2)}" '
                   f'pos="0 0 {_f(h / 2)}" rgba="{JOINT_RGBA}"/>')  # fmt: skip
    out.append(f'{indent}<site name="base" pos="{_vec(B[:3, 3])}" size="0.01" group="5"/>')
    for line in _link_geoms(factors[0], float(arm.radius[0]), origin=B[:3, 3]):
        out.append(indent + line)
    parent = B @ F[0]
    out.append(f'{indent}<body name="link1" {_pose(parent)} gravcomp="1">')
    for i in range(arm.n):
        indent = "  " * (4 + i)
        r = float(arm.radius[i])
        out.append(
            f'{indent}<joint name="joint{i + 1}" range="{_f(arm.lower[i])} {_f(arm.upper[i])}"/>'
        )
        out.append(f'{indent}<geom class="housing" size="{_f(1.15 * r)} {_f(1.1 * r)}"/>')
        last = i == arm.n - 1
        for line in _link_geoms(factors[i + 1], r, arm.marker_radius + r if last else 0.0):
            out.append(indent + line)
        if not last:
            out.append(f'{indent}<body name="link{i + 2}" {_pose(F[i + 1])} gravcomp="1">')
    tcp = F[arm.n]
    indent = "  " * (3 + arm.n)
    out.append(f'{indent}<site name="tcp" {_pose(tcp)} size="0.005" group="5"/>')
    out.append(f'{indent}<geom name="marker_tcp" class="marker" pos="{_vec(tcp[:3, 3])}"/>')
    if arm.grasp_box is not None:
        out += [indent + line for line in hand_geoms(tcp)]
    for i in reversed(range(arm.n)):
        out.append("  " * (3 + i) + "</body>")
    out += ["    </body>", "  </worldbody>", "  <actuator>"]
    for i in range(arm.n):
        kp, kv = inertia[i] * SERVO_FREQUENCY**2, 2 * inertia[i] * SERVO_FREQUENCY
        out.append(f'    <position class="{cls}" name="joint{i + 1}" joint="joint{i + 1}" '
                   f'kp="{kp:.4g}" kv="{kv:.4g}"/>')  # fmt: skip
    home, rdy = _vec(arm.home), _vec(ready)
    out += [
        "  </actuator>",
        "  <keyframe>",
        "    <!-- home: the table's home column; ready: the tcp at the target box's centre. -->",
        f'    <key name="home" qpos="{home}" ctrl="{home}"/>',
        f'    <key name="ready" qpos="{rdy}" ctrl="{rdy}"/>',
        *grasp_key(arm),
        "  </keyframe>",
        "</mujoco>",
        "",
    ]
    return "\n".join(out)


def grasp_key(arm: DHArm) -> list[str]:
    """The keyframe ``grasp_ready``, the pose task's taught pose, for a table with ``[grasp]``."""
    if arm.grasp_box is None:
        return []
    from models.dh_grasp import grasp_ready  # it builds on this module's ready_pose

    pose = _vec(grasp_ready(arm))
    return [
        "    <!-- grasp_ready: the pose task's taught pose, the centre of its joint box. -->",
        f'    <key name="grasp_ready" qpos="{pose}" ctrl="{pose}"/>',
    ]


def ready_pose(arm: DHArm) -> np.ndarray:
    """All n joints (n,): the fewest controlled joints' ``ready`` (the tcp at the target box's
    centre), the others at home."""
    joints = arm.controlled[0]
    return np.concatenate([arm_kinematics(arm, joints).ready, arm.home[joints:]])


def hand_geoms(tcp: np.ndarray) -> list[str]:
    """The pose task's hand in the last link's frame, the tool frame at ``tcp`` (4, 4) there: the
    marker frame's spheres (:data:`~models.marker_frame.MARKER_OFFSETS`) in the hand's colours,
    on a crossbar and a post as the PUMA's."""
    red, green, blue = (tcp[:3, :3] @ offset + tcp[:3, 3] for offset in MARKER_OFFSETS)
    root = tcp[:3, :3] @ np.array([0.0, 0.0, MARKER_OFFSETS[0, 2]]) + tcp[:3, 3]
    lines = [
        "<!-- The pose task's hand (drawn only by its grasp env; the reach task hides it): the "
        "marker frame of models/marker_frame.py at the tcp, massless, never colliding. -->",
        f'<geom name="hand_crossbar" class="post" fromto="{_vec(green)} {_vec(red)}"/>',
        f'<geom name="hand_post" class="post" fromto="{_vec(root)} {_vec(blue)}"/>',
    ]
    for colour, centre in zip(HAND_COLOURS, (red, green, blue), strict=True):
        lines.append(f'<geom name="hand_marker_{colour}" class="hand_marker" '
                     f'pos="{_vec(centre)}" rgba="{MARKER_RGBA[colour]}"/>')  # fmt: skip
    return lines


# -- the scene -----------------------------------------------------------------------------------


def camera_points(arm: DHArm) -> np.ndarray:
    """The points the sensing cameras frame: tcp positions of seeded random joint vectors."""
    return sample_reachable(arm, np.random.default_rng(CAMERA_SEED), WORKSPACE_SAMPLES)


def cameras(arm: DHArm) -> tuple[Camera, Camera, Camera]:
    """The scene's ``cam_left``, ``cam_right`` and ``overview``, on the target box's side."""
    return place_cameras(camera_points(arm), 0.5 * (arm.workspace_lower + arm.workspace_upper))


def scene_xml(arm: DHArm) -> str:
    """``scene.xml``: the robot, floor, light, the three cameras, the mocap target."""
    centre = 0.5 * (arm.workspace_lower + arm.workspace_upper)
    points = camera_points(arm)
    left, right, overview = cameras(arm)
    extent = 2 * float(np.max(np.linalg.norm(points - points.mean(axis=0), axis=-1)))
    return "\n".join([
        f"<!-- {arm.title} scene: generated by visuomotor-make-arm (models/dh_mjcf.py). The "
        f"stereo pair frames the tcp over {WORKSPACE_SAMPLES} random joint vectors (seed "
        f"{CAMERA_SEED}) with a {CAMERA_MARGIN:.0%} margin; targets are drawn from the box "
        f"{_vec(arm.workspace_lower)} .. {_vec(arm.workspace_upper)} (world, m). -->",
        f'<mujoco model="{arm.name} scene">',
        f'  <include file="{arm.name}.xml"/>',
        f'  <statistic center="{_vec(points.mean(axis=0))}" extent="{_f(extent)}"/>',
        "  <visual>",
        '    <global offwidth="1280" offheight="960" azimuth="120" elevation="-25"/>',
        '    <headlight diffuse="0.5 0.5 0.5" ambient="0.25 0.25 0.25" specular="0 0 0"/>',
        '    <quality shadowsize="2048"/>',
        "  </visual>",
        "  <asset>",
        '    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.86 0.89 0.93" '
        'rgb2="0.62 0.67 0.74" width="64" height="384"/>',
        '    <texture name="grid" type="2d" builtin="checker" rgb1="0.6 0.6 0.6" '
        'rgb2="0.48 0.48 0.48" width="256" height="256" mark="edge" markrgb="0.72 0.72 0.72"/>',
        '    <material name="grid" texture="grid" texrepeat="8 8" rgba="0.55 0.6 0.68 1" '
        'reflectance="0.1"/>',
        "  </asset>",
        "  <worldbody>",
        '    <light name="key" pos="1 1.5 3" dir="-0.3 -0.4 -1" directional="true" '
        'diffuse="0.7 0.7 0.7"/>',
        '    <geom name="floor" type="plane" size="8 8 0.05" material="grid" contype="0" '
        'conaffinity="0"/>',
        f"    {left.mjcf()}",
        f"    {right.mjcf()}",
        f"    {overview.mjcf()}",
        f'    <body name="target" mocap="true" pos="{_vec(centre)}">',
        f'      <geom name="target" type="sphere" size="{_f(arm.marker_radius)}" group="1" '
        'contype="0" conaffinity="0" rgba="0.9 0.1 0.1 1"/>',
        "    </body>",
        "  </worldbody>",
        "</mujoco>",
        "",
    ])  # fmt: skip


def scene_grasp_xml(arm: DHArm) -> str:
    """``scene_grasp.xml``: ``scene.xml`` and the pose task's object, a mocap body carrying the
    marker frame (red, green, blue) where the hand is at ``grasp_ready``."""
    from models.dh_grasp import grasp_ready  # it builds on this module's ready_pose

    ready = joint_frames(arm, grasp_ready(arm))[1]
    spheres = [
        f'      <geom name="object_marker_{colour}" class="object_marker" pos="{_vec(offset)}" '
        f'rgba="{MARKER_RGBA[colour]}"/>'
        for colour, offset in zip(MARKER_COLOURS, MARKER_OFFSETS, strict=True)
    ]
    red, green, blue = MARKER_OFFSETS
    return "\n".join([
        f"<!-- {arm.title} pose-task scene: generated by visuomotor-make-arm "
        "(models/dh_mjcf.py). The reach scene and the object, the marker frame of "
        "models/marker_frame.py in its own frame: the hand grasps it when its tool frame (site "
        "tcp) is the object's frame. -->",
        f'<mujoco model="{arm.name} grasp scene">',
        '  <include file="scene.xml"/>',
        "  <default>",
        '    <default class="object">',
        '      <geom group="1" contype="0" conaffinity="0" mass="0" rgba="0.5 0.5 0.5 1"/>',
        '      <default class="object_post">',
        f'        <geom type="capsule" size="{POST_RADIUS}"/>',
        "      </default>",
        '      <default class="object_marker">',
        f'        <geom type="sphere" size="{OBJECT_MARKER_RADIUS}"/>',
        "      </default>",
        "    </default>",
        "  </default>",
        "  <worldbody>",
        f'    <body name="object" mocap="true" {_pose(ready)}>',
        f'      <geom name="object_crossbar" class="object_post" fromto="{_vec(green)} '
        f'{_vec(red)}"/>',
        f'      <geom name="object_post" class="object_post" fromto="0 0 {_f(red[2])} '
        f'{_vec(blue)}"/>',
        *spheres,
        "    </body>",
        "  </worldbody>",
        "</mujoco>",
        "",
    ])  # fmt: skip


# -- the folder ----------------------------------------------------------------------------------

INIT_PY = '''"""{title}: generated from its DH table ({table}) by visuomotor-make-arm; its
:class:`~models.robot_model.RobotModel` is read from that table."""

from pathlib import Path

from models.dh_arm import dh_robot_model, read_table

TABLE = read_table(Path(__file__).with_name("{table}"))
MODEL = dh_robot_model(TABLE)
'''


def readme(arm: DHArm, table: str) -> str:
    rows = "\n".join(
        f"| {i + 1} | {arm.a[i]:.6g} | {arm.d[i]:.6g} | {math.degrees(arm.alpha[i]):.6g} | "
        f"{math.degrees(arm.offset[i]):.6g} | {math.degrees(arm.lower[i]):.6g} .. "
        f"{math.degrees(arm.upper[i]):.6g} | {math.degrees(arm.home[i]):.6g} | "
        f"{arm.radius[i]:.6g} |"
        for i in range(arm.n)
    )
    a, d, alpha, theta = arm.tool
    grasp, grasp_file = "", ""
    if arm.grasp_box is not None:
        from models.dh_grasp import grasp_ready  # it builds on this module's ready_pose

        half = ", ".join(f"{math.degrees(h):.6g}" for h in arm.grasp_box)
        centre = ", ".join(f"{math.degrees(h):.6g}" for h in grasp_ready(arm))
        grasp = (
            f"\n\nThe pose task (`models/dh_grasp.py`): objects where the hand is at joints "
            f"within ({half})° of the keyframe `grasp_ready` ({centre})°, in the joint ranges; "
            "the hand carries the marker frame of `models/marker_frame.py` at the tcp."
        )
        grasp_file = (
            "\n| `scene_grasp.xml` | `scene.xml` and the pose task's object (mocap `object`, "
            "its marker frame) |"
        )
    scenes = (
        "| `scene.xml` | the robot, floor, light, cameras `cam_left`, `cam_right`, `overview`, "
        f"`target` |{grasp_file}"
    )
    return f"""# {arm.title}

Generated from its DH table by `visuomotor-make-arm models/{arm.name}/{table} --out
models/{arm.name}` (`models/dh_mjcf.py`); edit the table and run it again rather than editing
the XML.

## Source

{arm.source}

## The table ({arm.convention} DH, `{table}`)

| joint | a (m) | d (m) | α (°) | θ offset (°) | range (°) | home (°) | link radius (m) |
|---|---|---|---|---|---|---|---|
{rows}

Tool (fixed, after joint {arm.n}): a = {a:.6g} m, d = {d:.6g} m, α = {math.degrees(alpha):.6g}°,
θ = {math.degrees(theta):.6g}°. Frame 0 (site `base`) stands {arm.base_height:.6g} m above the
floor. Reach {reach(arm):.4f} m (the tcp's largest distance from `base` over
{WORKSPACE_SAMPLES} random joint vectors). Reach targets: the box
{_vec(arm.workspace_lower)} .. {_vec(arm.workspace_upper)} m (world).{grasp}

## What is not from the source

Links are capsules of the radii above, with the density of water; every joint has armature
{ARMATURE} kg m² and damping {DAMPING} N m s/rad; each position servo is critically damped at
{SERVO_FREQUENCY:g} rad/s for the joint's largest inertia at home, ready and zero, and gravity
is compensated (`gravcomp`). The cameras `cam_left` and
`cam_right` are placed by `models.dh_mjcf.place_cameras` so that the tcp over
{WORKSPACE_SAMPLES} random joint vectors fills both 4:3 images with a {CAMERA_MARGIN:.0%} margin.

## Files

| file | holds |
|---|---|
| `{arm.name}.xml` | the robot: joints, servos, sites `base`, `tcp`, the marker, keyframes |
{scenes}
| `{table}` | the DH table this folder is generated from |
| `__init__.py` | `MODEL`: the robot's `RobotModel`, read from the table |
"""


def write_atomically(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder (never half)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as file:
            file.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_folder(arm: DHArm, folder: Path, table_name: str, table_text: str) -> list[Path]:
    """Write the robot folder (created if missing); returns the files written."""
    folder.mkdir(parents=True, exist_ok=True)
    files = {
        f"{arm.name}.xml": robot_xml(arm),
        "scene.xml": scene_xml(arm),
        "README.md": readme(arm, table_name),
        table_name: table_text,
        "__init__.py": INIT_PY.format(title=arm.title, table=table_name),
    }
    if arm.grasp_box is not None:
        files["scene_grasp.xml"] = scene_grasp_xml(arm)
    written = []
    for name, text in files.items():
        write_atomically(folder / name, text)
        written.append(folder / name)
    return written
