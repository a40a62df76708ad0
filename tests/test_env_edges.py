"""Edges of the env API through ``gym.make``: refused perturbations, refused actions and a step
before reset each raise one line naming what was wrong, and change nothing: the generator, the
simulation, the cameras. A run after the refused call equals a run without it."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import envs  # noqa: F401  (registers the envs)
from envs.perturb import PerturbationError

#: The model arrays a perturbation writes (cameras, sensed point, marker, base).
MODEL_FIELDS = ("cam_pos", "cam_quat", "cam_intrinsic", "cam_fovy", "site_pos", "geom_pos")
#: World points (m) whose projections stand for the cameras as the stereo rig sees them.
PROBES = np.array([[0.3, 0.5, 0.0], [0.1, 0.4, 0.2], [0.5, 0.2, 0.1]])
#: A change already in effect, so that "unchanged" is not just "nominal".
STANDING_CHANGE = {"camera_shift": [0.01, 0.0, 0.0], "tool": 0.02}
RIACS_COMMAND = np.array([0.7, 0.4, 1.5])  # rad, inside the joint ranges
TRACK_STEP = np.full(6, 0.01)  # rad


def _reach(**kwargs: Any) -> gym.Env:
    return gym.make("RiacsReach-v0", sensing="project", control="kinematic", **kwargs)


def _snapshot(env: gym.Env) -> dict[str, Any]:
    """Everything a refused call must leave alone."""
    base = env.unwrapped
    state = np.empty(mujoco.mj_stateSize(base.model, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(base.model, base.data, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    snap = {
        "rng": base.np_random.bit_generator.state,
        "simulation": state,
        "model": [getattr(base.model, name).copy() for name in MODEL_FIELDS],
        "body_pos": base.model.body_pos.copy(),
    }
    if hasattr(base, "perturbation"):  # the reach envs
        snap["cameras"] = base.stereo.project(PROBES)
        snap["perturbation"] = base.perturbation
        snap["sensed"] = (base.sensed_target(), base.sensed_effector())
    return snap


def _assert_unchanged(before: dict[str, Any], after: dict[str, Any]) -> None:
    assert after["rng"] == before["rng"]
    np.testing.assert_array_equal(after["simulation"], before["simulation"])
    for a, b in zip(after["model"], before["model"], strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(after["body_pos"], before["body_pos"])
    if "cameras" in before:
        np.testing.assert_array_equal(after["cameras"], before["cameras"])
        assert after["perturbation"] is before["perturbation"]
        np.testing.assert_array_equal(after["sensed"][0], before["sensed"][0])
        np.testing.assert_array_equal(after["sensed"][1], before["sensed"][1])


def _reach_run(env: gym.Env) -> list[np.ndarray]:
    """A random change drawn from the env's generator, then two episodes: every target,
    observation and camera, flattened."""
    base = env.unwrapped
    change = base.perturb(random={"camera_shift": 0.01, "zoom": 0.01, "tool": 0.01})
    out = [change.camera_shift, np.array([change.zoom, change.tool])]
    for _ in range(2):
        obs, info = env.reset()
        out += [info["target_pos"], *obs.values()]
        obs, reward, _, _, info = env.step(RIACS_COMMAND)
        out += [info["effector_pos"], np.array([reward]), *obs.values()]
    out.append(base.stereo.project(PROBES))
    return out


def _track_run(env: gym.Env) -> list[np.ndarray]:
    obs, _ = env.reset()
    out = list(obs.values())
    for _ in range(2):
        obs, reward, _, _, _ = env.step(TRACK_STEP)
        out += [np.array([reward]), *obs.values()]
    return out


def _assert_same_runs(a: list[np.ndarray], b: list[np.ndarray]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def _reference_reach_run(seed: int) -> list[np.ndarray]:
    """The run of an env that never saw the refused call."""
    env = _reach()
    env.reset(seed=seed)
    env.unwrapped.perturb(STANDING_CHANGE)
    run = _reach_run(env)
    env.close()
    return run


# -- perturbations --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"tool": "0.01"}, "tool must be a real number (m), got '0.01'"),
        ({"tool": True}, "tool must be a real number (m), got True"),
        ({"tool": [0.01]}, "tool must be one number (m), got shape (1,)"),
        ({"zoom": None}, "zoom must be a real number (focal length factor), got None"),
        ({"zoom": 99.0}, "zoom must be in [0.5, 2.0], got 99.0"),
        ({"zoom": 1.9}, "of the workspace is in both images"),  # in range, out of view
        (
            {"camera_shift": [[0.1, 0.2], [0.3, 0.4]]},
            "camera_shift must have shape (2, 3) or (3,) (m), got shape (2, 2)",
        ),
        ({"camera_turn": [0.0, 0.0, "0.1"]}, "camera_turn must be real numbers (rad), got '0.1'"),
        ({"camera_turn": np.array([True, False, True])}, "camera_turn must be real numbers"),
        ({"base_shift": [[0.0, 0.0, 0.1]]}, "base_shift must have shape (3,) (m), got shape"),
        ({"base_shift": [0.0, np.nan, 0.0]}, "base_shift must be finite"),
        ([("zoom", 1.1)], "a change must be a Perturbation, a dict of its fields"),
        ({"wobble": 1.0}, "unknown perturbation fields ['wobble']; valid: camera_shift"),
    ],
)
def test_refused_changes_name_the_field_and_change_nothing(change, message):
    env = _reach()
    env.reset(seed=5)
    env.unwrapped.perturb(STANDING_CHANGE)
    before = _snapshot(env)
    with pytest.raises(PerturbationError) as error:
        env.unwrapped.perturb(change)
    assert message in str(error.value) and "\n" not in str(error.value)
    _assert_unchanged(before, _snapshot(env))
    _assert_same_runs(_reach_run(env), _reference_reach_run(5))
    env.close()


@pytest.mark.parametrize(
    ("sizes", "message"),
    [
        ({"camera_shift": 10.0}, "random size camera_shift must be in [0, 0.5] (m), got 10.0"),
        ({"zoom": 0.8}, "random size zoom must be in [0, 0.5]"),  # 1 - 0.8 is below MIN_ZOOM
        ({"tool": -0.01}, "random size tool must be in [0, 0.5] (m), got -0.01"),
        ({"tool": "0.01"}, "random size tool must be a real number (m), got '0.01'"),
        ({"base_shift": [0.01, 0.02]}, "random size base_shift must be one number (m)"),
        ({"wobble": 0.1}, "unknown random sizes ['wobble']; valid: camera_shift"),
        ([("zoom", 0.01)], "random sizes must be a dict of field names to sizes"),
        # Valid sizes whose draw turns the cameras away from the workspace: refused after the
        # draw, which is undone.
        ({"camera_turn": 0.6}, "of the workspace is in both images"),
    ],
)
def test_refused_random_changes_leave_the_generator_as_it_was(sizes, message):
    env = _reach()
    env.reset(seed=5)
    env.unwrapped.perturb(STANDING_CHANGE)
    before = _snapshot(env)
    with pytest.raises(PerturbationError) as error:
        env.unwrapped.perturb(random=sizes)
    assert message in str(error.value) and "\n" not in str(error.value)
    _assert_unchanged(before, _snapshot(env))
    _assert_same_runs(_reach_run(env), _reference_reach_run(5))
    env.close()


def test_a_refused_seeded_random_change_refuses_a_bad_seed_first():
    env = _reach()
    env.reset(seed=5)
    before = _snapshot(env)
    with pytest.raises(ValueError, match=r"^seed must be an integer >= 0 or None, got 1\.5$"):
        env.unwrapped.perturb(random={"zoom": 0.01}, seed=1.5)
    _assert_unchanged(before, _snapshot(env))
    env.close()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"zoom": 99.0}, "zoom must be in [0.5, 2.0], got 99.0"),
        ({"zoom": 1.9}, "of the workspace is in both images"),
        ({"tool": "0.01"}, "tool must be a real number (m), got '0.01'"),
        ({"camera_shift": [[0.1, 0.2], [0.3, 0.4]]}, "camera_shift must have shape"),
    ],
)
def test_a_refused_reset_perturbation_does_not_reseed(change, message):
    env = _reach()
    env.reset(seed=5)
    env.unwrapped.perturb(STANDING_CHANGE)
    before = _snapshot(env)
    with pytest.raises(PerturbationError) as error:
        env.reset(seed=7, options={"perturb": change})
    assert message in str(error.value)
    _assert_unchanged(before, _snapshot(env))
    _assert_same_runs(_reach_run(env), _reference_reach_run(5))
    env.close()


def test_equivalent_spellings_of_a_change_give_the_same_scene():
    """(3,) for both cameras, integers and 0-d arrays are the same change as their floats."""
    spelled = _reach()
    spelled.reset(seed=1)
    spelled.unwrapped.perturb(
        {"camera_shift": [0.02, 0, 0], "zoom": 1, "tool": np.array(0.03), "base_shift": [0, 0, 0]}
    )
    written = _reach()
    written.reset(seed=1)
    written.unwrapped.perturb(
        {"camera_shift": [[0.02, 0.0, 0.0], [0.02, 0.0, 0.0]], "zoom": 1.0, "tool": 0.03}
    )
    _assert_same_runs(_reach_run(spelled), _reach_run(written))
    spelled.close()
    written.close()


# -- actions --------------------------------------------------------------------------------

BAD_ACTIONS = [
    (np.array([True, False, True]), "got bools array([True, False, True], dtype=bool)"),
    ([0.5, True, 1.0], "got True in [0.5, True, 1.0]"),
    (["0.1", "0.2", "0.3"], "got '0.1' in ['0.1', '0.2', '0.3']"),
    (np.array(["0.1", "0.2", "0.3"]), "got strings array(['0.1', '0.2', '0.3']"),
    ([0.5, None, 1.0], "got None in [0.5, None, 1.0]"),
    ("0.1", "got '0.1'"),
]


@pytest.mark.parametrize("normalize", [False, True])
@pytest.mark.parametrize(("action", "message"), BAD_ACTIONS)
def test_reach_refuses_bools_and_strings_and_changes_nothing(action, message, normalize):
    env = _reach(normalize=normalize)
    env.reset(seed=5)
    env.unwrapped.perturb(STANDING_CHANGE)
    before = _snapshot(env)
    with pytest.raises(ValueError) as error:
        env.step(action)
    assert str(error.value).startswith("action must be real numbers (rad), ")
    assert message in str(error.value) and "\n" not in str(error.value)
    _assert_unchanged(before, _snapshot(env))
    if not normalize:
        _assert_same_runs(_reach_run(env), _reference_reach_run(5))
    env.close()


@pytest.mark.parametrize(("action", "message"), BAD_ACTIONS)
def test_track_refuses_bools_and_strings_and_changes_nothing(action, message):
    action = np.resize(action, 6) if isinstance(action, np.ndarray) else action
    env = gym.make("PumaTrack-v0")
    env.reset(seed=4)
    env.step(TRACK_STEP)
    before = _snapshot(env)
    with pytest.raises(ValueError, match=r"^action must be real numbers \(rad\), got "):
        env.step(action)
    _assert_unchanged(before, _snapshot(env))
    after = _track_run(env)
    reference = gym.make("PumaTrack-v0")
    reference.reset(seed=4)
    reference.step(TRACK_STEP)
    _assert_same_runs(after, _track_run(reference))
    env.close()
    reference.close()


@pytest.mark.parametrize("normalize", [False, True])
def test_integer_actions_are_the_same_commands_as_their_floats(normalize):
    """Gymnasium's float64 Box contains integer arrays: integers are numbers, taken exactly."""
    integers = np.array([1, 0, 2]) if not normalize else np.array([1, 0, -1])
    runs = []
    for action in (integers, integers.tolist(), integers.astype(np.int32), integers.astype(float)):
        env = _reach(normalize=normalize)
        obs, _ = env.reset(seed=3)
        obs, reward, _, _, info = env.step(action)
        runs.append([*obs.values(), info["effector_pos"], np.array([reward, info["clipped"]])])
        env.close()
    for run in runs[:-1]:
        _assert_same_runs(run, runs[-1])
    track_runs = []
    for action in (np.array([0, 0, 0, 0, 0, 1]), np.array([0, 0, 0, 0, 0, 1.0])):
        env = gym.make("PumaTrack-v0")
        env.reset(seed=4)
        obs, reward, *_ = env.step(action)
        track_runs.append([*obs.values(), np.array([reward])])
        env.close()
    _assert_same_runs(*track_runs)


# -- step before reset ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("env_id", "action"),
    [
        ("RiacsReach-v0", RIACS_COMMAND),
        ("PumaReach-v0", RIACS_COMMAND),
        ("PumaTrack-v0", TRACK_STEP),
    ],
)
def test_step_before_reset_is_refused_wrapped_and_unwrapped(env_id, action):
    kwargs = {} if env_id == "PumaTrack-v0" else {"sensing": "project", "control": "kinematic"}
    env = gym.make(env_id, **kwargs)
    base = env.unwrapped
    qpos = base.data.qpos.copy()
    with pytest.raises(gym.error.ResetNeeded):  # Gymnasium's OrderEnforcing wrapper
        env.step(action)
    with pytest.raises(gym.error.ResetNeeded, match=r"^step\(\) before reset\(\): call env\.reset"):
        base.step(action)
    np.testing.assert_array_equal(base.data.qpos, qpos)
    env.reset(seed=2)
    after = env.step(action)[0]
    reference = gym.make(env_id, **kwargs)
    reference.reset(seed=2)
    _assert_same_runs(list(after.values()), list(reference.step(action)[0].values()))
    env.close()
    reference.close()
