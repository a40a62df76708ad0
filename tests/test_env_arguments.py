"""Env arguments are checked before any state or random number changes, and the error names the
argument."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the envs)
from envs.reach import ReachEnv
from envs.track import PumaTrackEnv


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"width": 0}, "width and height must be whole numbers"),
        ({"width": (320,)}, "width and height must be whole numbers"),
        ({"height": 240.5}, "got width=320, height=240.5"),
        ({"width": 8, "height": 6}, "width and height"),
        ({"width": 240, "height": 320}, "240x320 (width x height)"),
        ({"success_threshold": float("nan")}, "success_threshold"),
        ({"success_threshold": float("inf")}, "success_threshold"),
        ({"robot": ["riacs"]}, "unknown robot"),
        ({"sensing": None}, "unknown sensing"),
    ],
)
def test_reach_constructor_names_the_bad_argument(kwargs, named):
    with pytest.raises(ValueError) as error:
        ReachEnv(**{"sensing": "project", "control": "kinematic", **kwargs})
    assert named in str(error.value)


def _snapshot(env):
    base = env.unwrapped
    return base.np_random.bit_generator.state, base.data.qpos.copy(), base.data.mocap_pos.copy()


def _unchanged(env, before) -> None:
    after = _snapshot(env)
    assert after[0] == before[0]
    np.testing.assert_array_equal(after[1], before[1])
    np.testing.assert_array_equal(after[2], before[2])


@pytest.mark.parametrize(
    ("options", "named"),
    [([1], "reset options must be a dict"), ({"keep": True}, "unknown reset option 'keep'"),
     ({"keep_arm": "yes"}, "reset option 'keep_arm' got 'yes'")],
)  # fmt: skip
def test_reach_reset_refuses_bad_options_before_drawing_a_target(options, named):
    env = gym.make("RiacsReach-v0", sensing="project", control="kinematic")
    env.reset(seed=1)
    before = _snapshot(env)
    with pytest.raises(ValueError, match="keep_arm") as error:
        env.reset(options=options)
    assert named in str(error.value)
    _unchanged(env, before)


def test_complex_actions_are_refused_and_the_arm_does_not_move():
    env = gym.make("RiacsReach-v0", sensing="project", control="kinematic")
    env.reset(seed=1)
    before = _snapshot(env)
    with pytest.raises(ValueError, match="action must be real numbers"):
        env.step(np.array([0.5, 0.5, 1.0]) + 0.1j)
    _unchanged(env, before)
    track = PumaTrackEnv()
    track.reset(seed=2)
    qpos = track.data.qpos.copy()
    with pytest.raises(ValueError, match="action must be real numbers"):
        track.step(np.full(6, 0.01 + 0.01j))
    np.testing.assert_array_equal(track.data.qpos, qpos)


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [({"n_steps": 0}, "n_steps"), ({"n_steps": 2.5}, "n_steps"), ({"dt": 0.0}, "dt (s)"),
     ({"dt": float("nan")}, "dt (s)"), ({"circle_radius": -0.1}, "circle_radius (m)"),
     ({"circle_radius": float("nan")}, "circle_radius (m)")],
)  # fmt: skip
def test_track_constructor_names_the_bad_argument(kwargs, named):
    with pytest.raises(ValueError) as error:
        PumaTrackEnv(**kwargs)
    assert named in str(error.value)


def test_track_reset_refuses_a_missing_path_before_drawing():
    env = PumaTrackEnv()
    env.reset(seed=3)
    state, qpos = env.np_random.bit_generator.state, env.data.qpos.copy()
    with pytest.raises(ValueError, match=r"reset option 'path' got None; valid: \{'path'"):
        env.reset(options={"path": None})
    assert env.np_random.bit_generator.state == state
    np.testing.assert_array_equal(env.data.qpos, qpos)
