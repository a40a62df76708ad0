"""render_mode="human": MuJoCo's viewer opens and closes under a virtual X server (Xvfb, started
here), with the default MUJOCO_GL=egl; without a display, a clear error before any window."""

from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import sys
import textwrap

import pytest

import envs  # noqa: F401  (GL back-end)
from envs.reach import ReachEnv
from envs.viewer import DisplayUnavailableError

XVFB_START_TIMEOUT = 10.0  # s to wait for Xvfb to report its display number
CHILD_TIMEOUT = 120.0  # s; the child takes a few seconds (4 frames at render_fps = 4)

CHILD = textwrap.dedent(
    """
    import json
    import numpy as np
    import envs
    from envs.reach import ReachEnv

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
    print(json.dumps({"opened": opened, "closed": not handle.is_running(), "shown": shown}))
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


def test_human_viewer_opens_shows_target_and_marker_and_closes(xvfb_display):
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
    assert result == {"opened": True, "closed": True, "shown": {"target": 1, "marker_tcp": 1}}


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
