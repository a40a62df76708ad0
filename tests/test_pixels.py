"""Image observations (``obs_mode``), the render() frame's cost-saving settings, the quick info
copy and the goal-env wrapper that ``gym.make`` returns.

Images are compared with a second implementation: MuJoCo's own ``mujoco.Renderer``, one camera
at a time, set up here from the documented drawing settings.
"""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401  (registers the envs)
from envs.goal_env import GoalEnvWrapper
from envs.sensing.viewports import View, place_camera
from envs.step_info import StepInfo

ENV_IDS = ("RiacsReach-v0", "PumaReach-v0")
FAST = {"sensing": "project", "control": "kinematic"}
PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)
DOCUMENTED_PLANE_GRID = 0.5  # m, the floor's lighting grid in images and frames
SCENE_GROUPS = (0, 1, 2, 4)  # floor, target, robot, marker
IMAGE_FACETS = (16, 8)  # slices and stacks of the images' spheres and cylinders
MAX_ROUNDED = 1e-3  # fraction of colour values that may differ by one level from MuJoCo's own


def direct_render(
    env: gym.Env,
    camera: str | View,
    height: int,
    width: int,
    skybox: bool = False,
    textures: bool = False,
    facets: tuple[int, int] | None = IMAGE_FACETS,
    sphere_radius: float | None = None,
) -> np.ndarray:
    """One camera (a model camera's name, or a posed view) through mujoco.Renderer with the
    documented settings: no shadows, reflections or multisampling, meshes of ``facets`` (None:
    the model's), the floor's grid 0.5 m, target and marker at least ``sphere_radius`` m."""
    base = env.unwrapped
    model = copy.deepcopy(base.model)
    if sphere_radius is not None:
        spheres = np.concatenate([base.target_geom_ids, base.effector_geom_ids])
        model.geom_size[spheres, 0] = np.maximum(model.geom_size[spheres, 0], sphere_radius)
    if facets is not None:
        model.vis.quality.numslices, model.vis.quality.numstacks = facets
    model.vis.quality.offsamples = 0
    planes = model.geom_type == PLANE
    model.geom_size[planes, 2] = np.maximum(model.geom_size[planes, 2], DOCUMENTED_PLANE_GRID)
    renderer = mujoco.Renderer(model, height, width)
    try:
        flags = renderer.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = int(skybox)
        option = mujoco.MjvOption()
        option.flags[mujoco.mjtVisFlag.mjVIS_TEXTURE] = int(textures)
        option.geomgroup[:] = 0
        option.geomgroup[list(SCENE_GROUPS)] = 1
        if isinstance(camera, View):
            renderer.update_scene(base.data, camera=-1, scene_option=option)
            place_camera(renderer.scene, camera)
            mujoco.mjv_makeLights(model, base.data, renderer.scene)  # the view's own headlight
        else:
            renderer.update_scene(base.data, camera=camera, scene_option=option)
        return renderer.render().copy()
    finally:
        renderer.close()


def assert_same_image(got: np.ndarray, expected: np.ndarray) -> None:
    """Equal pixel for pixel, up to software GL's rounding of a colour interpolated at another
    place of another framebuffer: at most one level, in at most 0.1 % of the values."""
    assert got.shape == expected.shape and got.dtype == expected.dtype == np.uint8
    diff = np.abs(got.astype(int) - expected)
    assert diff.max() <= 1 and np.count_nonzero(diff) <= MAX_ROUNDED * diff.size


def _rollout(env: gym.Env, seed: int, steps: int = 3, check=None) -> list[dict[str, np.ndarray]]:
    """Observations of a reset and ``steps`` random moves; ``check(obs)`` after each."""
    obs, _ = env.reset(seed=seed)
    out = [obs]
    rng = np.random.default_rng(seed)
    space = env.action_space
    for _ in range(steps):
        if check is not None:
            check(out[-1])
        out.append(env.step(rng.uniform(space.low, space.high))[0])
    if check is not None:
        check(out[-1])
    return out


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("size", [(84, 84), (100, 60)])
def test_images_equal_a_direct_render_of_each_camera(env_id, size):
    """The pixel cameras' views, the spheres drawn large (apart: no see-through shell)."""
    width, height = size
    env = gym.make(env_id, obs_mode="pixels", pixels_width=width, pixels_height=height, **FAST)
    rig = env.unwrapped.pixel_rig

    def check(obs: dict[str, np.ndarray]) -> None:  # the scene is where obs was taken
        assert set(obs) == {"pixels_left", "pixels_right", "achieved_goal", "desired_goal"}
        for key, view in zip(("pixels_left", "pixels_right"), rig.views(), strict=True):
            assert obs[key].shape == (height, width, 3) and obs[key].dtype == np.uint8
            expected = direct_render(env, view, height, width, sphere_radius=rig.sphere_radius)
            assert_same_image(obs[key], expected)
        assert env.observation_space.contains(obs)

    _rollout(env, seed=3, check=check)
    env.close()


@pytest.mark.parametrize("sensing", ["project", "render"])
def test_pixel_modes_keep_the_state_observation_and_its_numbers(sensing):
    """The same seed gives the same joints, goals, rewards and infos in every obs_mode."""
    runs = {}
    for mode in ("state", "pixels", "state_pixels"):
        env = gym.make("RiacsReach-v0", obs_mode=mode, sensing=sensing, control="servo")
        obs, info = env.reset(seed=5)
        steps = [(obs, 0.0, info)]
        rng = np.random.default_rng(5)
        for _ in range(3):
            obs, reward, _, _, info = env.step(rng.uniform(env.action_space.low, 1.0))
            assert env.observation_space.contains(obs)
            steps.append((obs, reward, info))
        runs[mode] = steps
        env.close()
    assert set(runs["state_pixels"][0][0]) == {"observation", *runs["pixels"][0][0]}
    for (state, r0, i0), (pixels, r1, _), (both, r2, i2) in zip(*runs.values(), strict=True):
        assert r0 == r1 == r2 and i0["distance"] == i2["distance"]
        for key in ("achieved_goal", "desired_goal"):
            assert state[key].tobytes() == pixels[key].tobytes() == both[key].tobytes()
        assert state["observation"].tobytes() == both["observation"].tobytes()
        np.testing.assert_array_equal(pixels["pixels_left"], both["pixels_left"])


def test_images_are_deterministic_under_seeding_and_change_with_the_arm():
    make = lambda: gym.make("PumaReach-v0", obs_mode="pixels", **FAST)  # noqa: E731
    first, second = _rollout(make(), seed=11), _rollout(make(), seed=11)
    for a, b in zip(first, second, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    # A move is visible: consecutive images differ (the precondition of a useful observation).
    assert not np.array_equal(first[1]["pixels_left"], first[2]["pixels_left"])


def test_normalized_goals_with_images_stay_in_their_bounds():
    env = gym.make("RiacsReach-v0", obs_mode="state_pixels", normalize=True, **FAST)
    for obs in _rollout(env, seed=2, steps=4):
        assert env.observation_space.contains(obs)
        assert obs["pixels_left"].dtype == np.uint8
    env.close()


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"obs_mode": "image"}, "obs_mode"),
        ({"obs_mode": "pixels", "pixels_width": 0}, "pixels_width"),
        ({"obs_mode": "pixels", "pixels_height": 8.5}, "pixels_height"),
    ],
)
def test_bad_image_options_name_the_argument(kwargs, named):
    with pytest.raises(ValueError, match=named) as caught:
        gym.make("RiacsReach-v0", **kwargs)
    assert "\n" not in str(caught.value)


@pytest.mark.filterwarnings("ignore:.*symmetric and normalized")  # radians, by design
def test_gymnasium_check_env_passes_on_the_image_mode():
    env = gym.make("PumaReach-v0", obs_mode="pixels", **FAST)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_a_pickled_env_gives_the_same_images():
    """Pickled after it has rendered (GL resources are not pickled, the copy starts its own)."""
    env = gym.make("RiacsReach-v0", obs_mode="pixels", **FAST)
    env.reset(seed=1)
    clone = pickle.loads(pickle.dumps(env))
    for a, b in zip(_rollout(env, seed=8), _rollout(clone, seed=8), strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])


def _make_pixel_env():
    return gym.make("RiacsReach-v0", obs_mode="pixels", **FAST)


def test_async_vector_env_with_images_agrees_with_a_single_env():
    seeds = [40, 41]
    single = []
    for seed in seeds:
        env = _make_pixel_env()
        single.append(env.reset(seed=seed)[0])
        env.close()
    vec = gym.vector.AsyncVectorEnv([_make_pixel_env] * 2, context="forkserver")
    obs, _ = vec.reset(seed=seeds)
    vec.close()
    for k, expected in enumerate(single):
        for key, value in expected.items():
            np.testing.assert_array_equal(obs[key][k], value)
    assert not np.array_equal(obs["pixels_left"][0], obs["pixels_left"][1])  # two targets


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_render_frame_overview_equals_a_direct_render(env_id):
    """The frame's third panel (nothing drawn on it but its label, in the bottom fifth) is the
    overview camera as MuJoCo's renderer draws it with the frame's settings: skybox and textures
    on, shadows and reflections off."""
    env = gym.make(env_id, render_mode="rgb_array", **FAST)
    env.reset(seed=4)
    env.step(env.action_space.sample())
    frame = env.render()
    height, width = env.unwrapped.image_height, env.unwrapped.image_width
    assert frame.shape == (height, 3 * width, 3)
    expected = direct_render(
        env, "overview", height, width, skybox=True, textures=True, facets=None
    )
    above_label = slice(0, height - height // 5)
    assert_same_image(frame[above_label, 2 * width :], expected[above_label])
    env.close()


def test_step_info_deep_copy_is_a_deep_copy():
    info = StepInfo(
        {"distance": 0.25, "seen": True, "pos": np.arange(3.0), "flags": np.array([True, False])}
    )
    info["terminal_observation"] = {"achieved_goal": np.ones(4)}  # what SB3 adds
    copied = copy.deepcopy(info)
    reference = copy.deepcopy(dict(info))
    assert type(copied) is StepInfo and copied.keys() == reference.keys()
    for key, value in reference.items():
        if isinstance(value, dict):
            assert copied[key] is not info[key]
            np.testing.assert_array_equal(copied[key]["achieved_goal"], value["achieved_goal"])
            assert copied[key]["achieved_goal"] is not info[key]["achieved_goal"]
        else:
            np.testing.assert_array_equal(copied[key], value)
    copied["pos"][0] = 9.0
    assert info["pos"][0] == 0.0  # arrays are not shared
    assert isinstance(pickle.loads(pickle.dumps(info)), StepInfo)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gym_make_exposes_compute_reward(env_id):
    env = gym.make(env_id, **FAST)
    assert isinstance(env, GoalEnvWrapper)
    obs, info = env.reset(seed=6)
    obs, reward, _, _, info = env.step(env.action_space.sample())
    assert env.compute_reward(obs["achieved_goal"], obs["desired_goal"], info) == reward
    batch = np.stack([obs["achieved_goal"], obs["desired_goal"]])  # (2, 4)
    got = env.compute_reward(batch, batch[::-1], [info, info])
    np.testing.assert_array_equal(
        got, env.unwrapped.compute_reward(batch, batch[::-1], [info, info])
    )
    assert got[0] == reward
    again = gym.make(env.spec)  # the recorded wrapper is applied once, again
    assert isinstance(again, GoalEnvWrapper) and not isinstance(again.env, GoalEnvWrapper)


def test_record_video_writes_at_the_envs_frame_rate(tmp_path):
    pytest.importorskip("moviepy", reason="RecordVideo needs moviepy (pip install moviepy)")
    imageio = pytest.importorskip("imageio.v3")
    env = gym.make("RiacsReach-v0", render_mode="rgb_array", **FAST)
    env = gym.wrappers.RecordVideo(env, str(tmp_path / "videos"), episode_trigger=lambda _: True)
    env.reset(seed=0)
    truncated = False
    while not truncated:
        truncated = env.step(env.action_space.sample())[3]
    env.close()
    (video,) = (tmp_path / "videos").glob("*.mp4")
    assert imageio.immeta(video)["fps"] == env.metadata["render_fps"]


@pytest.mark.parametrize("env_id", [*ENV_IDS, "PumaGrasp-v0"])
def test_the_view_labels_lie_off_the_arm(env_id):
    """Where the frame's labels are drawn, MuJoCo's own segmentation of each camera view shows
    no robot or marker geom, at the start and after random moves."""
    env = gym.make(env_id, render_mode="rgb_array", **FAST)
    base = env.unwrapped
    height, width = base.image_height, base.image_width
    drawn = np.isin(base.model.geom_group, (2, 4))  # robot and marker groups
    renderer = mujoco.Renderer(base.model, height, width)
    renderer.enable_segmentation_rendering()
    rng, space = np.random.default_rng(9), env.action_space
    try:
        env.reset(seed=9)
        for move in range(40):
            for camera in ("cam_left", "cam_right"):
                left, top, right, bottom = base._view.label_box(camera)
                renderer.update_scene(base.data, camera=camera)
                ids, kinds = np.moveaxis(renderer.render()[top:bottom, left:right], -1, 0)
                geoms = ids[kinds == int(mujoco.mjtObj.mjOBJ_GEOM)]
                assert not drawn[geoms].any(), f"move {move}: the arm under {camera}'s label"
            env.step(rng.uniform(space.low, space.high))
    finally:
        renderer.close()
        env.close()
