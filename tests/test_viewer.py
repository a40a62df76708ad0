"""render_mode="human": MuJoCo's viewer opens and closes under a virtual X server (Xvfb, started
here), with the default MUJOCO_GL=egl, and the sensing is what it is without a window; without a
display, a clear error before any window. The window's first camera frames every registered
arm's base and target (a pinhole projection through MuJoCo's own camera of the scene)."""

from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import sys
import textwrap

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end)
from envs.reach import ReachEnv
from envs.robots import ROBOTS, grasp_env_ids
from envs.viewer import DisplayUnavailableError, frame_points, frame_scene

XVFB_START_TIMEOUT = 10.0  # s to wait for Xvfb to report its display number
CHILD_TIMEOUT = 180.0  # s; the child takes some seconds (10 frames at render_fps = 4)
#: The window's first view: base and targets within this fraction of its half-height from the
#: centre, and spread over at least FILLED of it (not a small arm in a field of floor).
INSIDE, FILLED = 0.95, 0.6
ENV_IDS = [*(spec.reach_env for spec in ROBOTS.values()), *grasp_env_ids()]

CHILD = textwrap.dedent(
    """
    import hashlib
    import json
    import numpy as np
    import envs
    from envs.reach import ReachEnv
    from learners import AnalyticIK


    def sensed(render_mode):
        \"\"\"Digest of every observation (sensed pixels, camera images) of two trials that
        reach their targets (the window then draws the target as a shell round the marker).\"\"\"
        env = ReachEnv(robot="riacs", sensing="render", control="kinematic",
                       obs_mode="state_pixels", render_mode=render_mode)
        ik = AnalyticIK.for_robot(env.nominal_stereo.triangulate, "riacs")
        digest = hashlib.sha256()
        for seed in (3, 4):  # the second episode's target is sensed after the first's reach
            obs, _ = env.reset(seed=seed)
            for _ in range(2):
                for key in sorted(obs):
                    digest.update(np.ascontiguousarray(obs[key]).tobytes())
                obs, *_ = env.step(ik.act(obs["desired_goal"]))
        env.close()
        return digest.hexdigest()


    env = ReachEnv(robot="riacs", sensing="render", control="kinematic", render_mode="human")
    env.reset(seed=0)
    handle = env.human_viewer.handle
    opened = handle.is_running()
    for command in np.linspace(env.joint_lower, env.joint_upper, 5)[1:-1]:
        env.step(command)
        assert env.render() is None
    groups = [int(g) for g in handle.opt.geomgroup]
    model = env.model
    shown = {
        name: groups[model.geom_group[model.geom(name).id]] for name in ("target", "marker_tcp")
    }
    env.close()
    same = sensed("human") == sensed(None)
    print(json.dumps({"opened": opened, "closed": not handle.is_running(), "shown": shown,
                      "same_sensing": same}))
    """
)


@pytest.fixture(scope="module")
def xvfb_display():
    """A display number of a private Xvfb server, stopped after the tests."""
    if shutil.which("Xvfb") is None:
        pytest.skip("Xvfb is not installed (Debian package xvfb; .ci/run installs it)")
    read, write = os.pipe()
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", "640x480x24", "-nolisten", "tcp"],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write)
    try:
        ready, _, _ = select.select([read], [], [], XVFB_START_TIMEOUT)
        number = os.read(read, 64).decode().strip() if ready else ""
        if not number:
            pytest.skip(f"Xvfb did not start within {XVFB_START_TIMEOUT} s")
        yield f":{number}"
    finally:
        os.close(read)
        server.terminate()
        server.wait()


def test_human_viewer_opens_shows_target_and_marker_leaves_sensing_and_closes(xvfb_display):
    env = {**os.environ, "DISPLAY": xvfb_display, "MUJOCO_GL": "egl"}
    done = subprocess.run(
        [sys.executable, "-c", CHILD],
        env=env,
        capture_output=True,
        text=True,
        timeout=CHILD_TIMEOUT,
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result == {
        "opened": True,
        "closed": True,
        "shown": {"target": 1, "marker_tcp": 1},
        "same_sensing": True,
    }


def test_without_a_display_a_clear_error(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    env = ReachEnv(robot="riacs", sensing="project", control="kinematic", render_mode="human")
    with pytest.raises(DisplayUnavailableError, match=r"DISPLAY is not set.*xvfb-run.*rgb_array"):
        env.reset(seed=0)
    env.close()


def test_an_unreachable_display_a_clear_error(monkeypatch):
    monkeypatch.setenv("DISPLAY", ":9999")  # no X server there
    env = ReachEnv(robot="riacs", sensing="project", control="kinematic", render_mode="human")
    with pytest.raises(DisplayUnavailableError, match=r"cannot open display ':9999'"):
        env.reset(seed=0)
    env.close()


def window_image(model: mujoco.MjModel, camera: mujoco.MjvCamera, points: np.ndarray) -> np.ndarray:
    """(N, 2) image offsets of world ``points`` (N, 3) from a square window's centre, per its
    half-height (±1 at its edges), through the OpenGL camera that MuJoCo makes of ``camera``."""
    scene = mujoco.MjvScene(model, maxgeom=1000)
    data = mujoco.MjData(model)
    mujoco.mjv_updateScene(
        model, data, mujoco.MjvOption(), None, camera, mujoco.mjtCatBit.mjCAT_ALL, scene
    )
    eye = scene.camera[0]  # the viewer's left eye = its only eye without stereo
    forward, up = np.asarray(eye.forward), np.asarray(eye.up)
    right = np.cross(forward, up)
    offset = points - np.asarray(eye.pos)  # (N, 3)
    depth = offset @ forward  # (N,)
    assert np.all(depth > eye.frustum_near), "a point behind the camera"
    half_height = (eye.frustum_top - eye.frustum_bottom) / 2 / eye.frustum_near  # per unit depth
    return np.stack([offset @ right, offset @ up], axis=1) / (depth[:, None] * half_height)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_the_window_opens_framed_on_base_and_target(env_id: str) -> None:
    env = gym.make(env_id, sensing="project", control="kinematic")
    for seed in (0, 1):
        env.reset(seed=seed)
        robot = env.unwrapped
        assert isinstance(robot, ReachEnv)
        model, data = robot.model, robot.data
        camera = mujoco.MjvCamera()
        scene = frame_points(model, data, robot.robot_spec.workspace)  # arm, workspace, targets
        frame_scene(camera, model, scene)
        base = data.xpos[model.body_rootid[model.jnt_bodyid[0]]]  # the arm's root body
        shown = window_image(model, camera, np.vstack([base, data.mocap_pos, scene]))
        assert np.all(np.abs(shown) <= INSIDE), np.abs(shown).max(axis=0)
        assert np.ptp(shown, axis=0).max() / 2 >= FILLED, np.ptp(shown, axis=0)
    env.close()
