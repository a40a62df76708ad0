"""Films of reach trials: the physics-step hook changes no number, servo moves are sampled at the
video's rate, kinematic moves are interpolated, and two films stack stage by stage."""

from __future__ import annotations

import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import envs  # noqa: F401  (registers the envs, chooses the GL back-end)
from envs.cli.controllers import make_controller
from envs.composite import CompositeView
from envs.harness.film import HOLD_SECONDS, INTERPOLATION_SECONDS, TrialFilm, side_by_side
from envs.harness.trials import run_trial
from envs.reach import ReachEnv
from envs.viewer import frame_points, frame_scene

PANEL = (160, 120)  # small panels: the tests count frames, they do not look at them


class _SettleTimes(gym.Wrapper):
    """Keeps ``info["settle_time"]`` of every step."""

    def __init__(self, env) -> None:
        super().__init__(env)
        self.settle_times: list[float] = []

    def step(self, action):
        result = super().step(action)
        self.settle_times.append(result[4]["settle_time"])
        return result


def test_physics_step_hook_changes_no_number_and_sees_every_step():
    plain = ReachEnv(robot="riacs", sensing="project", control="servo")
    hooked = ReachEnv(robot="riacs", sensing="project", control="servo")
    calls: list[float] = []
    hooked.on_physics_step = calls.append
    plain.reset(seed=4)
    hooked.reset(seed=4)
    command = np.array([0.6, 0.5, 1.4])
    obs_a, reward_a, *_, info_a = plain.step(command)
    obs_b, reward_b, *_, info_b = hooked.step(command)
    assert reward_a == reward_b and info_a["distance"] == info_b["distance"]
    np.testing.assert_array_equal(plain.data.qpos, hooked.data.qpos)
    for key in obs_a:
        np.testing.assert_array_equal(obs_a[key], obs_b[key])
    steps = round(info_b["settle_time"] / hooked.model.opt.timestep)
    assert len(calls) == steps
    np.testing.assert_allclose(calls, hooked.model.opt.timestep * np.arange(1, steps + 1))


@pytest.fixture(scope="module")
def servo_film():
    env = _SettleTimes(gym.make("RiacsReach-v0", sensing="project", control="servo"))
    env.reset(seed=2)
    film = TrialFilm(env, "test", fps=20.0, speed=2.0, panel=PANEL)
    trial, stages = film.trial(make_controller("analytic", env), 1, "trial 1/1")
    film.close()
    yield env, trial, stages
    env.close()


def test_servo_moves_are_sampled_every_speed_over_fps_seconds(servo_film):
    env, trial, stages = servo_film
    hold = round(HOLD_SECONDS * 20.0)
    assert len(stages) == 1 + len(trial.commands)  # the new target, then each move
    assert len(stages[0]) == hold
    interval = 2.0 / 20.0  # s of simulated time between frames
    for stage, settle in zip(stages[1:], env.settle_times, strict=True):
        # Frames at t = 0.002, 0.1, 0.2, ... s (the first physics step, then every interval).
        assert len(stage) == math.floor(settle / interval + 1e-9) + 1 + hold
    assert all(f.shape == stages[0][0].shape for s in stages for f in s)


def test_a_filmed_trial_gives_the_numbers_of_an_unfilmed_one(servo_film):
    _, filmed, _ = servo_film
    env = gym.make("RiacsReach-v0", sensing="project", control="servo")
    env.reset(seed=2)
    plain = run_trial(env, make_controller("analytic", env), 1)
    env.close()
    assert plain.distances == filmed.distances
    for a, b in zip(plain.sensed_px, filmed.sensed_px, strict=True):
        np.testing.assert_array_equal(a, b)


def test_kinematic_moves_are_interpolated_from_the_last_pose():
    env = gym.make("RiacsReach-v0", sensing="project", control="kinematic")
    env.reset(seed=3)
    film = TrialFilm(env, "test", fps=10.0, panel=PANEL)
    trial, stages = film.trial(make_controller("analytic", env), 0, "trial")
    moving = round(INTERPOLATION_SECONDS * 10.0)
    assert len(stages[1]) == moving + round(HOLD_SECONDS * 10.0)
    first, last_moving, end = stages[1][0], stages[1][moving - 1], stages[1][-1]
    assert not np.array_equal(first, last_moving)  # the arm moves in the interpolation
    band = end.shape[0] - PANEL[1]  # the overlay text differs; the pictures below must not
    # The last interpolated pose is the pose the env reached (the end frame adds the marker).
    view = film.view
    nothing = np.full(4, np.nan)
    expected = view.render(env.unwrapped.data, trial.target_px, nothing, [])
    np.testing.assert_array_equal(last_moving[band:, 2 * PANEL[0] :], expected[:, 2 * PANEL[0] :])
    film.close()
    env.close()


def test_side_by_side_stacks_stage_by_stage_holding_the_shorter():
    def film(lengths, value):
        return [[np.full((2, 3, 3), value + i, np.uint8) for i in range(n)] for n in lengths]

    top, bottom = film([2, 3], 10), film([1, 5, 2], 100)
    frames = side_by_side([top, bottom], gap=1)
    assert len(frames) == 2 + 5 + 2
    assert all(f.shape == (5, 3, 3) for f in frames)
    assert frames[1][0, 0, 0] == 11 and frames[1][3, 0, 0] == 100  # bottom held its last frame
    assert frames[-1][0, 0, 0] == 12 and frames[-1][3, 0, 0] == 101  # top held its last stage


def test_panel_pixels_are_sensing_pixels_scaled_like_a_larger_sensor():
    small = ReachEnv(robot="puma560", sensing="project", control="kinematic")
    large = ReachEnv(robot="puma560", sensing="project", control="kinematic", width=640, height=480)
    view = CompositeView(small.model, 480, 640, sensing_size=(320, 240))
    point = np.array([[0.05, 0.5, 0.7]])
    np.testing.assert_allclose(
        view.to_panel(small.stereo.project(point)), large.stereo.project(point), atol=1e-9
    )
    view.close()


@pytest.mark.parametrize("robot", ["puma560", "riacs"])
def test_viewer_camera_frames_the_arm_and_the_workspace(robot):
    """Every robot body at home and the corners of the target workspace lie inside the window's
    vertical field of view and a 4:3 horizontal one, seen from MuJoCo's free-camera pose."""
    env = ReachEnv(robot=robot, sensing="project", control="kinematic")
    camera = mujoco.MjvCamera()
    frame_scene(camera, env.model, frame_points(env.model, env.data, env.robot_spec.workspace))
    az, el = np.deg2rad(camera.azimuth), np.deg2rad(camera.elevation)
    forward = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    eye = camera.lookat - camera.distance * forward
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    targets = env.robot_spec.workspace.sample(np.random.default_rng(0), 200)
    points = np.vstack([env.data.xpos[1:], targets])  # (bodies + 200, 3) m
    rel = points - eye
    depth = rel @ forward
    half_v = np.deg2rad(env.model.vis.global_.fovy) / 2
    half_h = np.arctan(np.tan(half_v) * 4 / 3)
    assert np.all(depth > 0)
    assert np.all(np.abs(np.arctan2(rel @ up, depth)) < half_v)
    assert np.all(np.abs(np.arctan2(rel @ right, depth)) < half_h)
    env.close()


def test_video_program_stacks_two_controllers_on_the_same_targets(tmp_path):
    import cv2

    from envs.cli import video

    out = video.main(["--env", "RiacsReach-v0", "--controller", "analytic", "--compare", "random",
                      "--sensing", "project", "--control", "kinematic", "--trials", "1",
                      "--fine-moves", "0", "--fps", "10",
                      "--out", str(tmp_path / "v.mp4")])  # fmt: skip
    capture = cv2.VideoCapture(str(out))
    # Target shown, then the coarse move: interpolation and hold, at 10 frames a second.
    expected = (
        round(HOLD_SECONDS * 10) + round(INTERPOLATION_SECONDS * 10) + round(HOLD_SECONDS * 10)
    )
    assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == expected
    assert int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)) == 3 * 600  # three 600-pixel panels
    assert int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)) > 2 * 450  # two films, one above the other
    capture.release()


def test_docs_gif_loops_with_the_written_frames(tmp_path, monkeypatch):
    import imageio.v3 as iio

    from envs.cli import docs_media

    colours = [(230, 30, 30), (30, 230, 30), (30, 30, 230)]
    frames = [np.full((8, 12, 3), c, dtype=np.uint8) for c in colours]
    path = docs_media.write_gif(frames, tmp_path / "a" / "x.gif", fps=5.0)
    back = iio.imread(path)
    assert back.shape[0] == 3
    np.testing.assert_allclose(back[:, 4, 6, :3], colours, atol=8)
    assert iio.immeta(path, index=0).get("loop") == 0  # loops forever
    monkeypatch.setattr(docs_media, "MAX_BYTES", 10)
    with pytest.raises(ValueError, match="over 10"):
        docs_media.write_gif(frames, tmp_path / "y.gif", fps=5.0)
