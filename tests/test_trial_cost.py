"""A trial's cost cut without changing a bit: the envs' own path (renderings reused, windows that
cannot show the marker skipped, the settle test on floats) against the plain path, over random
moves; the work counters against counts made by hand; the parts one by one."""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import envs  # noqa: F401  (GL back-end before mujoco)
from envs.reach import SETTLE_SPEED, moving, moving_numpy
from envs.scene import INTEGRATION_STATE
from envs.sensing.foveated import CULL_MARGIN_PX
from envs.sensing.marker_detection import GREEN_EFFECTOR, Blob, edges_in, outline_edges
from envs.sensing.render_memo import RenderMemo
from envs.studies.trial_cost import settle_step, use_plain_path
from learners import AnalyticIK

REALISTIC = {"sensing": "foveated", "control": "servo"}


def _state(env) -> bytes:
    state = np.empty(mujoco.mj_stateSize(env.model, INTEGRATION_STATE))
    mujoco.mj_getState(env.model, env.data, state, INTEGRATION_STATE)
    return state.tobytes()


def _same(a, b) -> None:
    """Observations or infos equal bit for bit (NaN where the other has NaN)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            _same(a[key], b[key])
    elif isinstance(a, tuple):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _same(x, y)
    else:
        assert np.asarray(a).tobytes() == np.asarray(b).tobytes(), (a, b)


def _commands(env, rng: np.random.Generator) -> list[np.ndarray]:
    """A random move, one near the target (the exact grasp or IK, a little off) and one onto
    it: the whole images, the windows and the hidden cases all come up."""
    base = env.unwrapped
    if hasattr(base, "target_joints"):  # the grasp env
        exact = base.target_joints.copy()
    else:
        ik = AnalyticIK.for_robot(base.nominal_stereo.triangulate, base.robot, base.joints)
        exact = ik.solve(base.data.mocap_pos[base.target_mocap_id][None])[0][0]
    space = base.action_space
    near = exact + rng.normal(0.0, 0.02, exact.shape)
    return [rng.uniform(space.low, space.high), near, exact]


@pytest.mark.parametrize(
    ("env_id", "sensing", "episodes"),
    [
        ("RiacsReach-v0", "foveated", 6),
        ("PumaReach-v0", "foveated", 6),
        ("PumaGrasp-v0", "foveated", 2),
        ("RiacsReach-v0", "render", 4),
    ],
)
def test_the_envs_path_gives_the_plain_paths_moves_bit_for_bit(env_id, sensing, episodes):
    """Every observation, reward and info, and the final simulation state, of the default env
    equal those of an env on the plain path (every view drawn, every window rendered, the
    numpy settle test), over resets home and where the arm was, and a moved camera."""
    default = gym.make(env_id, sensing=sensing, control="servo").unwrapped
    plain = gym.make(env_id, sensing=sensing, control="servo").unwrapped
    use_plain_path(plain)
    rng = np.random.default_rng(7)
    for episode in range(episodes):
        options = {"keep_arm": episode % 3 == 2}
        if episode == episodes - 1:
            options["perturb"] = {"camera_shift": [0.01, 0.0, -0.01]}  # the renderings go stale
        _same(*(env.reset(seed=episode, options=options) for env in (default, plain)))
        for command in _commands(default, rng):
            _same(*(env.step(command) for env in (default, plain)))
        assert _state(default) == _state(plain)
    # The grasp's arm starts out of view and its sensing draws the object: nothing to reuse.
    assert (default.stereo.reused > 0) == (env_id != "PumaGrasp-v0") and plain.stereo.reused == 0
    assert default.stereo.renders[0] < plain.stereo.renders[0]
    assert default.physics_steps == plain.physics_steps
    default.close()
    plain.close()


def test_the_counters_count_what_a_reset_and_a_move_do_by_hand():
    """RIACS on the plain path, the marker at home far from the target: a reset renders the
    target's whole images and then its windows, the marker's windows (which miss it), the whole
    images and windows where they found it: 5 renderings of 2 views each, two sensings that
    rendered the whole images (the target's always does). The
    default path skips the windows that miss (4), and at the next reset home draws the marker's
    again from the kept ones (2). A servo move counts its settle time's physics steps; a
    kinematic one none."""
    plain = gym.make("RiacsReach-v0", **REALISTIC).unwrapped
    use_plain_path(plain)
    plain.reset(seed=0)
    counts = plain.work_counts()
    assert (counts.renders, counts.views, counts.fallbacks) == (5, 10, 2)
    assert counts.physics_steps == 0
    default = gym.make("RiacsReach-v0", **REALISTIC).unwrapped
    default.reset(seed=0)
    counts = default.work_counts()
    assert (counts.renders, counts.views, counts.fallbacks) == (4, 8, 2)
    assert default.fovea.skipped == 1
    default.reset(seed=1)
    counts = default.work_counts() - counts
    assert (counts.renders, counts.views, counts.fallbacks) == (2, 4, 2)
    assert default.stereo.reused == 2
    before = default.work_counts()
    _, _, _, _, info = default.step(default.action_space.sample())
    steps = (default.work_counts() - before).physics_steps
    assert steps == round(info["settle_time"] / default.model.opt.timestep) > 10
    kinematic = gym.make("RiacsReach-v0", sensing="project", control="kinematic").unwrapped
    kinematic.reset(seed=0)
    kinematic.step(kinematic.action_space.sample())
    assert kinematic.work_counts().physics_steps == 0 and kinematic.work_counts().renders == 0
    for env in (plain, default, kinematic):
        env.close()


def test_the_settle_test_on_floats_is_numpys():
    """moving gives moving_numpy's answer: speeds about the threshold, at it exactly, infinite,
    and NaN (numpy's maximum is then NaN: not moving)."""
    rng = np.random.default_rng(0)
    cases = [rng.normal(0.0, SETTLE_SPEED, n) for n in (1, 3, 6, 7) for _ in range(500)]
    edge = [SETTLE_SPEED, -SETTLE_SPEED, np.nextafter(SETTLE_SPEED, 0.0), 0.0, -0.0]
    cases += [np.array(edge[i : i + 3]) for i in range(3)]
    for odd in (np.nan, np.inf, -np.inf):
        for speeds in ([odd, 0.0, 0.0], [0.0, 2 * SETTLE_SPEED, odd], [odd, -1.0]):
            cases.append(np.array(speeds))
    cases.append(np.array([np.inf, -np.inf]))
    for qvel in cases:
        assert moving(qvel) == moving_numpy(qvel), qvel


def test_a_window_that_cannot_show_the_marker_shows_none_of_it():
    """Over random poses and windows placed about guesses up to 30 px off: wherever can_show
    says no, rendering those windows finds no blob of the marker's colour in either; and it says
    no often enough to matter."""
    env = gym.make("PumaReach-v0", **REALISTIC).unwrapped
    env.reset(seed=0)
    fovea, stereo = env.fovea, env.stereo
    rng = np.random.default_rng(3)
    refused = 0
    for _ in range(60):
        env.set_joints(rng.uniform(env.joint_lower, env.joint_upper))
        centre = env.sensed_point()
        true = stereo.project(centre[None])[0]
        guess = true + rng.uniform(-30.0, 30.0, 4)
        windows = fovea.windows(guess, env.marker_radius)
        if fovea.can_show(windows, centre, env.marker_radius):
            continue
        refused += 1
        seen = stereo.sense_sphere(env.data, GREEN_EFFECTOR, env.marker_radius, windows)
        assert seen.blank.all(), (true, windows)
    assert refused >= 10
    env.close()


def _images() -> list[tuple[np.ndarray, np.ndarray]]:
    return [(np.zeros((2, 2, 3), np.uint8), np.zeros((2, 2)))]


def test_the_memo_keeps_the_renderings_that_were_reused():
    """A full memo drops the oldest rendering never reused (a pose passed through), else the
    oldest; kept images are read-only."""
    memo = RenderMemo(kept=3)
    draws = []

    def get(name: str) -> None:
        memo.get(((), (), name.encode()), lambda: draws.append(name) or _images())

    for name in ("home", "a", "home", "b", "c", "d", "home", "e", "f", "g", "home"):
        get(name)  # more poses passed through between two resets home than the memo holds
    assert draws == ["home", "a", "b", "c", "d", "e", "f", "g"]
    assert memo.reused == 3
    images = memo.get(((), (), b"home"), _images)
    with pytest.raises(ValueError, match="read-only"):
        images[0][0][0, 0, 0] = 1


def test_a_rendering_is_drawn_again_when_what_it_shows_changed():
    """The key follows the arm, the cameras and the geoms' colours, not the target that the
    marker's sensing does not draw."""
    env = gym.make("RiacsReach-v0", **REALISTIC).unwrapped
    env.reset(seed=0)
    stereo, memo = env.stereo, RenderMemo()
    groups = (0, 2, 4)

    def key():
        return memo.key(env.model, env.data, groups, stereo.views())

    first = key()
    env.data.mocap_pos[env.target_mocap_id] += 0.1  # the target, not drawn
    mujoco.mj_forward(env.model, env.data)
    assert key() == first
    env.set_joints(env.data.qpos[env.qpos_ids] + 1e-9)  # the arm, a little
    assert key() != first
    env.reset(seed=0)
    assert key() == first
    env.model.geom_rgba[env.effector_geom_ids[0], 1] -= 0.01  # the marker's colour
    assert key() != first
    env.model.geom_rgba[env.effector_geom_ids[0], 1] += 0.01
    env.perturb({"zoom": 1.01})  # the cameras: the views' intrinsics and MuJoCo's
    assert key() != first
    env.close()


def test_the_studys_settle_rule_ends_each_move_where_the_env_did():
    """settle_step, the study's copy of the settle rule, ends every recorded servo move at its
    last physics step with the env's own speed, and no later with a faster one."""
    env = gym.make("PumaReach-v0", sensing="project", control="servo").unwrapped
    env.reset(seed=0)
    trace: list[tuple[float, float]] = []
    env.on_physics_step = lambda t: trace.append((t, float(np.abs(env.data.qvel).max())))
    rng = np.random.default_rng(1)
    for _ in range(8):
        trace.clear()
        env.step(rng.uniform(env.action_space.low, env.action_space.high))
        elapsed, speeds = (np.array(column) for column in zip(*trace, strict=True))
        assert settle_step(elapsed, speeds, SETTLE_SPEED) == len(trace) - 1
        assert settle_step(elapsed, speeds, 10 * SETTLE_SPEED) < len(trace) - 1
    env.close()


def test_a_culled_whole_image_is_the_full_one_about_the_marker():
    """Whole images that draw only the geoms reaching near the marker's image give, over random
    poses, the full drawing's colours and depths about the marker (the culled part less its
    margin) and the same sighting; without the margin some views differ near its edge."""
    env = gym.make("PumaReach-v0", **REALISTIC).unwrapped
    env.reset(seed=0)
    fovea, stereo = env.fovea, env.stereo
    stereo.reuse_renders = False
    groups = (0, 2, 4)  # floor, robot, marker: the arm's whole images
    rng = np.random.default_rng(5)
    for _ in range(60):
        env.set_joints(rng.uniform(env.joint_lower, env.joint_upper))
        culls = fovea.regions(env.sensed_point()[None], env.marker_radius)
        full = stereo.render_views(env.data, groups)
        culled = stereo._renderer.render(env.data, stereo.views(None, culls), groups)
        for (rgb, depth), (rgb_c, depth_c), part in zip(full, culled, culls, strict=True):
            if part is None:
                continue
            top, left = (round(x + CULL_MARGIN_PX + 0.5) for x in (part.top, part.left))
            rows = slice(max(top, 0), max(top + part.height - 2 * round(CULL_MARGIN_PX), 0))
            cols = slice(max(left, 0), max(left + part.width - 2 * round(CULL_MARGIN_PX), 0))
            assert rgb[rows, cols].tobytes() == rgb_c[rows, cols].tobytes()
            assert depth[rows, cols].tobytes() == depth_c[rows, cols].tobytes()
        seen = stereo.sense_many(env.data, [GREEN_EFFECTOR], env.marker_radius)[0]
        seen_c = stereo.sense_many(env.data, [GREEN_EFFECTOR], env.marker_radius, culls=culls)[0]
        _same(seen, seen_c)
    env.close()


def test_outline_edges_scan_the_blobs_box_and_find_the_whole_views_points():
    """outline_edges, which scans the blob's bounding box and a pixel round it, gives the
    points of edges_in over the whole view, in the same order, bit for bit: blobs in the
    middle, at each border and in a corner, with specks."""
    rng = np.random.default_rng(2)
    shape = (60, 80)
    rows, cols = np.mgrid[: shape[0], : shape[1]]
    for centre in [(30, 40), (0, 40), (59, 40), (30, 0), (30, 79), (0, 0), (59, 79)]:
        disc = (rows - centre[0]) ** 2 + (cols - centre[1]) ** 2 < 9.0**2
        mask = disc | ((rng.random(shape) < 0.01) & (abs(rows - centre[0]) < 12))
        depth = rng.uniform(1.0, 1.2, shape)
        blob = Blob(mask, int(mask.sum()), False)
        points = outline_edges(blob, depth, 0.01)
        assert len(points) > 10
        assert points.tobytes() == edges_in(mask, depth, 0.01).tobytes()
