"""Off-screen rendering of the scenes: markers appear where a pinhole camera puts them, every
workspace point is in view, both GL back-ends agree, and the renderer's errors are helpful.

The projection and the colour detection are written here from MuJoCo's camera definition
(pose, ``fovy`` or ``sensorsize``/``focal``/``principal``), independently of
``envs.sensing.stereo`` and ``envs.sensing.marker_detection``.
"""

from __future__ import annotations

import ctypes.util
import json
import math
import os
import subprocess
import sys
from dataclasses import dataclass

import mujoco
import numpy as np
import pytest

import models
from envs.robots import ROBOTS
from envs.scene import hide_geoms
from envs.sensing.rendering import CameraRenderer
from models import puma560, riacs

HEIGHT, WIDTH = 240, 320  # px, the sensing image size
CAMERAS = ("cam_left", "cam_right")
GROUPS_TARGET = (0, 1)  # floor + target: nothing can hide the target
GROUPS_EFFECTOR = (0, 2, 4)  # floor + robot + effector markers
HIDDEN_GROUP = 5  # a geom group the tests never draw
RING_POINTS = 12  # lines of sight per ring through a marker's disc
DISC_RINGS = (0.35, 0.7)  # ring radii, fractions of the marker's radius
MIN_VISIBLE_SHARE = 0.75  # a marker counts as in view when this share of its disc is seen
MAX_CANDIDATES = 10  # arm poses drawn per pose kept (the rest hide their marker)
N_POSES = 30
BACKEND_TOL = 0.5  # px, EGL and OSMesa put a marker at the same pixels
SUBPROCESS_TIMEOUT = 120  # s
#: A pixel belongs to a marker when its own channel is bright and dominates the other two.
MIN_CHANNEL, DOMINANCE = 60, 2.0
MIN_BLOB_PIXELS = 4
RIACS_FOCAL, RIACS_HALF_SEPARATION = 1.0, 0.3  # the report's camera(f=1, d=0.3)


# --------------------------------------------------------------------------- helpers


@dataclass(frozen=True)
class Camera:
    """A MuJoCo camera as a pinhole: world pose and the image window in normalised coordinates."""

    position: np.ndarray  # (3,) world
    rotation: np.ndarray  # (3, 3), columns: camera x (right), y (up), z (backwards)
    window: np.ndarray  # (4,) normalised (x_left, x_right, y_bottom, y_top), y up

    def normalized(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World points (N, 3) -> normalised coordinates (N, 2) (x right, y up), depth (N,)."""
        local = (np.atleast_2d(points) - self.position) @ self.rotation  # (N, 3)
        depth = -local[:, 2]
        return local[:, :2] / depth[:, None], depth

    def pixels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World points (N, 3) -> pixel (u, v) (N, 2) with pixel centres at integers, depth (N,).

        The window maps linearly onto the image: x_left to the left edge of column 0 (u = -0.5),
        x_right to the right edge of the last column, y_top to the top edge of row 0.
        """
        xy, depth = self.normalized(points)
        x_left, x_right, y_bottom, y_top = self.window
        u = (xy[:, 0] - x_left) / (x_right - x_left) * WIDTH - 0.5
        v = (y_top - xy[:, 1]) / (y_top - y_bottom) * HEIGHT - 0.5
        return np.stack([u, v], axis=-1), depth

    @property
    def pixels_per_unit(self) -> float:
        """Focal length in pixels (square pixels in both scenes)."""
        return HEIGHT / (self.window[3] - self.window[2])


def camera(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> Camera:
    """Read a camera. With ``fovy`` the window is symmetric: ±tan(fovy/2) vertically, scaled by
    the aspect ratio horizontally. With a physical sensor (``sensorsize``, ``focal``,
    ``principal``), the window is the sensor divided by the focal length, its centre shifted by
    the principal point: (+px/fx, -py/fy) in x-right/y-up coordinates (MuJoCo measures the
    principal point with y downwards)."""
    cid = model.camera(name).id
    sx, sy = model.cam_sensorsize[cid]
    if sy > 0:
        fx, fy, px, py = model.cam_intrinsic[cid]
        cx, cy = px / fx, -py / fy
        half_w, half_h = sx / (2 * fx), sy / (2 * fy)
    else:
        half_h = math.tan(math.radians(model.cam_fovy[cid]) / 2)
        half_w = half_h * WIDTH / HEIGHT
        cx = cy = 0.0
    window = np.array([cx - half_w, cx + half_w, cy - half_h, cy + half_h])
    return Camera(data.cam_xpos[cid].copy(), data.cam_xmat[cid].reshape(3, 3).copy(), window)


def blob_centroid(rgb: np.ndarray, channel: int) -> np.ndarray | None:
    """Centroid (u, v) of the pixels where ``channel`` (0 red, 1 green) is bright and dominant."""
    image = rgb.astype(int)
    own = image[..., channel]
    others = np.delete(image, channel, axis=-1)  # (H, W, 2)
    mask = (own >= MIN_CHANNEL) & np.all(own[..., None] >= DOMINANCE * others, axis=-1)
    rows, cols = np.nonzero(mask)
    if len(rows) < MIN_BLOB_PIXELS:
        return None
    return np.array([cols.mean(), rows.mean()])


def puma_pose(rng: np.random.Generator, wrist: np.ndarray) -> np.ndarray:
    """Joint angles (6,) that put the wrist centre at the world point ``wrist`` (right-above,
    joints 1-3 shifted by 2π into range), with random in-range wrist joints."""
    theta, reachable = puma560.wrist_ik(wrist - puma560.BASE_POS, 1, 1)
    assert reachable
    lower, upper = puma560.DH.lower, puma560.DH.upper
    for shift in (0.0, -2 * math.pi, 2 * math.pi):
        theta = np.where((theta < lower[:3]) | (theta > upper[:3]), theta + shift, theta)
    return np.concatenate([theta, rng.uniform(lower[3:], upper[3:])])


def arm_poses(name: str, rng: np.random.Generator, n: int) -> np.ndarray:
    """n random arm poses whose effector is in (PUMA: the wrist centre) or near the workspace."""
    if name == "puma560":
        wrists = puma560.WORKSPACE.sample(rng, n)
        return np.stack([puma_pose(rng, w) for w in wrists])
    return rng.uniform(riacs.LOWER, riacs.UPPER, size=(n, 3))


def assert_found_near(rgb: np.ndarray, channel: int, uv: np.ndarray, radius_px: float, what: str):
    found = blob_centroid(rgb, channel)
    assert found is not None, f"{what}: no marker pixels, expected at {uv}"
    error = float(np.hypot(*(found - uv)))
    assert error <= radius_px, f"{what}: found at {found}, projected {uv}, {error:.2f} px apart"


def visible_share(model, data, eye: np.ndarray, geom_id: int) -> float:
    """Share of lines of sight from ``eye`` through the disc of the sphere ``geom_id`` (its
    centre and rings at DISC_RINGS of its radius) whose first hit among the drawn groups
    GROUPS_EFFECTOR is the sphere itself (MuJoCo ray casting). Robot parts inside the sphere
    do not count: they are hidden by it."""
    centre, radius = data.geom_xpos[geom_id], model.geom_size[geom_id][0]
    sight = centre - eye
    sight /= np.linalg.norm(sight)
    e1 = np.cross(sight, [0.0, 0.0, 1.0] if abs(sight[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(sight, e1)
    angles = np.linspace(0, 2 * math.pi, RING_POINTS, endpoint=False)
    ring = np.cos(angles)[:, None] * e1 + np.sin(angles)[:, None] * e2  # (RING_POINTS, 3)
    offsets = np.vstack([np.zeros(3), *(f * radius * ring for f in DISC_RINGS)])
    drawn = np.zeros(6, dtype=np.uint8)
    drawn[list(GROUPS_EFFECTOR)] = 1
    hit = np.zeros(1, dtype=np.int32)
    reached = 0
    for point in centre + offsets:
        mujoco.mj_ray(model, data, eye, point - eye, drawn, 1, -1, hit)
        reached += hit[0] == geom_id
    return reached / len(offsets)


@pytest.fixture(scope="module", params=["puma560", "riacs"])
def scene(request):
    model = models.load_model(request.param)
    grasp = ROBOTS[request.param].grasp
    if grasp is not None:  # the grasp task's gripper and markers, hidden as the reach envs do
        hide_geoms(model, grasp.geoms)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    renderer = CameraRenderer(model, HEIGHT, WIDTH)
    yield request.param, model, data, renderer
    renderer.close()


# --------------------------------------------------------------------------- geometry


def test_riacs_cameras_are_the_reports_camera():
    """Normalised coordinates of the MuJoCo cameras equal camera(f=1, d=0.3) of the report."""
    model = models.load_model("riacs")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    p = riacs.WORKSPACE.sample(np.random.default_rng(3), 500)
    x1, y1, x2, y2 = riacs.camera(RIACS_FOCAL, RIACS_HALF_SEPARATION, *p.T)
    left, _ = camera(model, data, "cam_left").normalized(p)
    right, _ = camera(model, data, "cam_right").normalized(p)
    np.testing.assert_allclose(left, np.stack([x1, y1], axis=-1), atol=1e-9)
    np.testing.assert_allclose(right, np.stack([x2, y2], axis=-1), atol=1e-9)


def test_every_workspace_point_is_inside_both_images(scene):
    name, model, data, _ = scene
    workspace = getattr(models, name).WORKSPACE
    points = workspace.sample(np.random.default_rng(4), 5000)
    if name == "puma560":  # the box's corners are its extreme points
        corners = np.stack(np.meshgrid(*np.stack([workspace.lower, workspace.upper]).T), -1)
        points = np.concatenate([points, corners.reshape(-1, 3)])
    else:  # the reachable set's boundary: the arm at a grid over its joint box, faces included
        axes = [np.linspace(lo, hi, 25) for lo, hi in zip(riacs.LOWER, riacs.UPPER, strict=True)]
        theta = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        tip = np.stack(riacs.robot3df(riacs.LINK1, riacs.LINK2, *theta.T), axis=-1)
        points = np.concatenate([points, tip])
    radius = model.geom("target").size[0]
    for cam_name in CAMERAS:
        cam = camera(model, data, cam_name)
        uv, depth = cam.pixels(points)
        assert np.all(depth > radius)
        margin = radius * cam.pixels_per_unit / depth  # the marker's image radius, px
        inside = (
            (uv[:, 0] - margin >= -0.5)
            & (uv[:, 0] + margin <= WIDTH - 0.5)
            & (uv[:, 1] - margin >= -0.5)
            & (uv[:, 1] + margin <= HEIGHT - 0.5)
        )
        assert inside.all(), f"{name} {cam_name}: {points[~inside][:3]} project outside"


# --------------------------------------------------------------------------- rendering


def test_target_is_found_where_projected(scene):
    name, model, data, renderer = scene
    targets = getattr(models, name).WORKSPACE.sample(np.random.default_rng(5), N_POSES)
    radius = model.geom("target").size[0]
    cams = [camera(model, data, c) for c in CAMERAS]
    for target in targets:
        data.mocap_pos[model.body("target").mocapid[0]] = target
        mujoco.mj_forward(model, data)
        for cam_name, cam in zip(CAMERAS, cams, strict=True):
            image = renderer.render(data, cam_name, GROUPS_TARGET)
            uv, depth = cam.pixels(target)
            limit = radius * cam.pixels_per_unit / depth[0]
            assert_found_near(image, 0, uv[0], limit, f"{name} {cam_name} target {target}")


def test_effector_markers_are_found_where_projected(scene):
    """Each green marker (PUMA: tcp and wrist centre, one at a time) at N_POSES random arm poses
    where the robot hides at most a small part of it (a thin link crossing it) in both cameras."""
    name, model, data, renderer = scene
    names = {model.geom(i).name for i in range(model.ngeom)} & {"marker_tcp", "marker_wrist"}
    assert "marker_tcp" in names
    qidx = [model.joint(f"joint{i + 1}").qposadr[0] for i in range(model.nu)]
    cams = [camera(model, data, c) for c in CAMERAS]
    candidates = arm_poses(name, np.random.default_rng(6), MAX_CANDIDATES * N_POSES)
    saved = model.geom_group.copy()
    try:
        for marker in sorted(names):
            model.geom_group[:] = saved
            for other in names - {marker}:  # hide the other green marker
                model.geom_group[model.geom(other).id] = HIDDEN_GROUP
            geom = model.geom(marker)
            tested = 0
            for q in candidates:
                data.qpos[qidx] = q
                mujoco.mj_forward(model, data)
                centre, radius = data.geom_xpos[geom.id].copy(), geom.size[0]
                shares = [visible_share(model, data, c.position, geom.id) for c in cams]
                if min(shares) < MIN_VISIBLE_SHARE:
                    continue
                for cam_name, cam in zip(CAMERAS, cams, strict=True):
                    image = renderer.render(data, cam_name, GROUPS_EFFECTOR)
                    uv, depth = cam.pixels(centre)
                    limit = radius * cam.pixels_per_unit / depth[0]
                    assert_found_near(image, 1, uv[0], limit, f"{name} {cam_name} {marker} q={q}")
                tested += 1
                if tested == N_POSES:
                    break
            assert tested == N_POSES, f"{name} {marker}: only {tested} unoccluded poses"
    finally:
        model.geom_group[:] = saved


# --------------------------------------------------------------------------- back-ends

_RENDER_SCRIPT = """
import json, sys
import envs
import mujoco
import mujoco.gl_context
import numpy as np
import models
from envs.sensing.rendering import CameraRenderer

args = json.loads(sys.argv[1])
model = models.load_model(args["name"])
data = mujoco.MjData(model)
data.qpos[:] = args["qpos"]
data.mocap_pos[0] = args["target"]
mujoco.mj_forward(model, data)
renderer = CameraRenderer(model, args["height"], args["width"])
images = {}
for cam in args["cameras"]:
    for what, groups in (("target", (0, 1)), ("effector", (0, 2, 4))):
        images[f"{cam}/{what}"] = renderer.render(data, cam, groups)
renderer.close()
np.savez(args["out"], module=mujoco.gl_context.GLContext.__module__, **images)
"""


def _run(code: str, env_update: dict, cwd, *argv: str) -> subprocess.CompletedProcess:
    """``python -c code *argv`` in a fresh interpreter, the GL variables replaced by env_update."""
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    env.update(env_update)
    return subprocess.run(
        [sys.executable, "-c", code, *argv],
        env=env,
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=SUBPROCESS_TIMEOUT,
    )


def _render_in_subprocess(backend: str, args: dict, tmp_path) -> dict[str, np.ndarray]:
    """Run _RENDER_SCRIPT in a fresh interpreter with MUJOCO_GL=backend; its images by key."""
    out = tmp_path / f"{backend}.npz"
    result = _run(
        _RENDER_SCRIPT, {"MUJOCO_GL": backend}, tmp_path, json.dumps({**args, "out": str(out)})
    )
    assert result.returncode == 0, f"MUJOCO_GL={backend} failed:\n{result.stderr[-2000:]}"
    with np.load(out) as saved:
        return {key: saved[key] for key in saved.files}


@pytest.mark.parametrize("name", ["puma560", "riacs"])
def test_egl_and_osmesa_put_markers_at_the_same_pixels(name, tmp_path):
    if ctypes.util.find_library("EGL") is None:
        pytest.skip("libEGL is not installed")
    if ctypes.util.find_library("OSMesa") is None:
        reason = "libOSMesa is not installed (Debian: apt-get install libosmesa6)"
        print(f"skipping the OSMesa comparison: {reason}")
        pytest.skip(reason)
    model = models.load_model(name)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(8)
    q = arm_poses(name, rng, 1)[0]
    qpos = model.key("home").qpos.copy()
    qpos[[model.joint(f"joint{i + 1}").qposadr[0] for i in range(model.nu)]] = q
    target = getattr(models, name).WORKSPACE.sample(rng, 1)[0]
    args = {
        "name": name,
        "qpos": qpos.tolist(),
        "target": target.tolist(),
        "height": HEIGHT,
        "width": WIDTH,
        "cameras": list(CAMERAS),
    }
    egl = _render_in_subprocess("egl", args, tmp_path)
    osmesa = _render_in_subprocess("osmesa", args, tmp_path)
    assert str(egl["module"]) == "mujoco.egl" and str(osmesa["module"]) == "mujoco.osmesa"
    data.qpos[:] = qpos
    data.mocap_pos[0] = target
    mujoco.mj_forward(model, data)
    marker = "marker_tcp"
    for cam_name in CAMERAS:
        cam = camera(model, data, cam_name)
        for what, channel, centre, radius in (
            ("target", 0, target, model.geom("target").size[0]),
            ("effector", 1, data.geom(marker).xpos, model.geom(marker).size[0]),
        ):
            key = f"{cam_name}/{what}"
            a, b = blob_centroid(egl[key], channel), blob_centroid(osmesa[key], channel)
            assert a is not None and b is not None, key
            assert np.hypot(*(a - b)) <= BACKEND_TOL, f"{key}: EGL {a} vs OSMesa {b}"
            if what == "target":  # the effector image also holds the other green marker
                uv, depth = cam.pixels(centre)
                assert np.hypot(*(a - uv[0])) <= radius * cam.pixels_per_unit / depth[0], key


# --------------------------------------------------------------------------- errors


def test_renderer_rejects_images_larger_than_the_buffer():
    model = models.load_model("riacs")
    width, height = model.vis.global_.offwidth, model.vis.global_.offheight
    for size in ((height + 1, WIDTH), (HEIGHT, width + 1)):
        with pytest.raises(ValueError, match="offwidth") as info:
            CameraRenderer(model, *size)
        assert "offheight" in str(info.value) and f"{width}x{height}" in str(info.value)


_PROJECT_THEN_RENDER = """
import envs, gymnasium as gym
from envs.sensing.rendering import RenderingUnavailableError, gl_libraries_loaded
env = gym.make("RiacsReach-v0", sensing="project", control="kinematic")
env.reset(seed=0)
_, _, _, _, info = env.step(env.unwrapped.joint_lower + 0.3)
print("project", info["visible"], "GL loaded:", gl_libraries_loaded())
try:
    gym.make("RiacsReach-v0", sensing="render", control="kinematic").reset(seed=0)
    print("rendered")
except RenderingUnavailableError as exc:
    print("ERROR", exc)
"""


@pytest.mark.parametrize("backend", ["osmesa", "egl"])
def test_project_sensing_needs_no_gl_and_a_broken_library_is_named(backend, tmp_path):
    """A folder of broken GL libraries first on LD_LIBRARY_PATH: libEGL and libOSMesa are found
    but do not load (or are not found at all). Exact projection works, loads no GL library, and
    rendering raises RenderingUnavailableError naming the library and the fix."""
    broken = tmp_path / "lib"
    broken.mkdir()
    for name in ("libEGL.so.1", "libEGL.so", "libOSMesa.so", "libOSMesa.so.8", "libOSMesa.so.6"):
        (broken / name).write_bytes(b"not a shared library")
    env = {"MUJOCO_GL": backend, "LD_LIBRARY_PATH": str(broken)}
    result = _run(_PROJECT_THEN_RENDER, env, tmp_path)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0] == "project True GL loaded: False"
    library = {"egl": "libEGL", "osmesa": "libOSMesa"}[backend]
    assert lines[1].startswith(f"ERROR MUJOCO_GL={backend}: {library}"), lines[1]
    assert "apt-get install libosmesa6" in lines[1]


def test_unset_backend_prefers_egl_then_osmesa_even_if_mujoco_came_first(tmp_path):
    expected = next(
        (b for b, lib in (("egl", "EGL"), ("osmesa", "OSMesa")) if ctypes.util.find_library(lib)),
        None,
    )
    if expected is None:
        pytest.skip("neither libEGL nor libOSMesa is installed")
    code = (
        "import mujoco, os, envs, models\n"
        "from envs.sensing.rendering import render_camera\n"
        "model = models.load_model('riacs')\n"
        "data = mujoco.MjData(model)\n"
        "mujoco.mj_forward(model, data)\n"
        "image = render_camera(model, data, 'cam_left')\n"
        "print(os.environ['MUJOCO_GL'], image.std() > 0)\n"
    )
    result = _run(code, {}, tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split()[-2:] == [expected, "True"]


def test_fork_guard_sees_gl_started_outside_the_project(tmp_path):
    """The parent renders with mujoco.Renderer directly, then forks: the child's first
    CameraRenderer refuses (instead of hanging), because libEGL is mapped into the process."""
    if ctypes.util.find_library("EGL") is None:
        pytest.skip("libEGL is not installed")
    code = (
        "import os, mujoco, envs, models\n"
        "from envs.sensing.rendering import CameraRenderer, RenderingUnavailableError\n"
        "model = models.load_model('riacs')\n"
        "data = mujoco.MjData(model)\n"
        "renderer = mujoco.Renderer(model, 64, 64)\n"
        "renderer.update_scene(data, camera='cam_left'); renderer.render()\n"
        "pid = os.fork()\n"
        "if pid == 0:\n"
        "    try:\n"
        "        CameraRenderer(model, 64, 64).render(data, 'cam_left')\n"
        "    except RenderingUnavailableError as exc:\n"
        "        print('child refused:', 'forked after its parent' in str(exc))\n"
        "        os._exit(3)\n"
        "    os._exit(0)\n"
        "print('child exit', os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))\n"
    )
    result = _run(code, {"MUJOCO_GL": "egl"}, tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split("\n")[:2] == ["child refused: True", "child exit 3"]


def test_unusable_backend_error_names_both_backends(tmp_path):
    """An EGL device that does not exist: the renderer's error says what to do."""
    if ctypes.util.find_library("EGL") is None:
        pytest.skip("libEGL is not installed")
    code = (
        "import envs, mujoco, models\n"
        "from envs.sensing.rendering import CameraRenderer, RenderingUnavailableError\n"
        "model = models.load_model('riacs')\n"
        "try:\n"
        "    CameraRenderer(model, 240, 320).render(mujoco.MjData(model), 'cam_left')\n"
        "except RenderingUnavailableError as exc:\n"
        "    print('ERROR', exc)\n"
    )
    result = _run(code, {"MUJOCO_GL": "egl", "MUJOCO_EGL_DEVICE_ID": "999"}, tmp_path)
    assert result.returncode == 0, result.stderr
    message = result.stdout
    assert message.startswith("ERROR"), message
    for word in ("MUJOCO_GL=egl", "MUJOCO_GL=osmesa", "libosmesa6"):
        assert word in message, f"{word!r} missing from: {message}"


@pytest.mark.parametrize(("backend", "library"), [("egl", "EGL"), ("osmesa", "OSMesa")])
def test_an_env_used_in_a_fork_of_the_process_that_rendered_it_refuses(backend, library, tmp_path):
    """The parent renders an env, then forks at a random moment of a short wait: the child that
    steps the inherited env gets RenderingUnavailableError naming the processes (an inherited
    GL context would hang), and the parent's env still renders."""
    if ctypes.util.find_library(library) is None:
        pytest.skip(f"lib{library} is not installed")
    code = (
        "import os, random, time, gymnasium as gym, numpy as np, envs\n"
        "from envs.sensing.rendering import RenderingUnavailableError\n"
        "env = gym.make('RiacsReach-v0', sensing='render', control='kinematic')\n"
        "env.reset(seed=0); env.step(env.action_space.sample())\n"
        "time.sleep(random.uniform(0.0, 0.2))\n"
        "pid = os.fork()\n"
        "if pid == 0:\n"
        "    try:\n"
        "        env.step(env.action_space.sample())\n"
        "    except RenderingUnavailableError as exc:\n"
        "        print('child refused:', f'process {os.getppid()}' in str(exc), flush=True)\n"
        "        os._exit(3)\n"
        "    os._exit(0)\n"
        "code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])\n"
        "obs = env.step(env.action_space.sample())[0]\n"
        "print('child exit', code, np.isfinite(obs['observation']).any())\n"
        "env.close()\n"
    )
    result = _run(code, {"MUJOCO_GL": backend}, tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split("\n")[:2] == ["child refused: True", "child exit 3 True"]
