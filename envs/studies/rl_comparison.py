"""The visuomotor map against deep RL (Stable-Baselines3) on one reach env and setting.

Every method gets the same budget of environment steps (one step = one move, as the env counts
it) and is evaluated at the same checkpoints on the same held-out targets: evaluation set
``EVAL_SET`` of the evaluation stream (:mod:`envs.harness.streams`; no training env, however
often Stable-Baselines3 reseeds it, draws from that stream), one target per episode of
``MAX_EPISODE_STEPS`` moves. The score of an
episode is the ground-truth distance (``info["distance"]``) after its last move; a map trial that
stopped because a marker was not seen keeps the distance where the arm stopped. Stable-Baselines3
and torch are imported only by :func:`train_sb3` (the ``rl`` extra).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from envs.harness.streams import seed_env
from envs.harness.training import RunConfig, initial_grasp_map, initial_map
from envs.harness.trials import learn_from, run_trial
from envs.reach import MAX_EPISODE_STEPS

METHODS = ("map", "sac_her", "sac", "ppo", "sac_pixels")


class Store(Protocol):
    """What a resumable SB3 run needs of its folder (``envs.studies.rl_runs.Store`` is one)."""

    def resume(self, method: str, venv: Any) -> tuple[Any, Any, Curve] | None: ...

    def save_model(self, model: Any, venv: Any, train_seconds: float) -> None: ...

    def save_curve(self, curve: Curve) -> None: ...


THRESHOLDS = (0.010, 0.005, 0.001)  # m: report the steps needed to reach these mean distances
#: m: success curves, the fraction of held-out episodes whose final distance is below each.
SUCCESS_THRESHOLDS = (0.005, 0.010, 0.020)
EVAL_SET = 0  # the held-out targets: this set of the evaluation stream
MAP_TRAIN_MOVES = 2  # a training trial: coarse move + one fine move, as envs.harness.training
#: Stable-Baselines3 settings: RL Zoo's tuned FetchReach (her.yml) values for the off-policy
#: agents (the closest published task: a goal env whose episodes are a few moves), and RL Zoo's
#: Reacher settings (ppo.yml) for PPO. Learning starts after LEARNING_STARTS_FRACTION of the
#: budget (at most 1000 steps, Zoo's value).
SAC_KWARGS: dict[str, Any] = {
    "batch_size": 256,
    "gamma": 0.95,
    "learning_rate": 1e-3,
    "policy_kwargs": {"net_arch": [64, 64], "n_critics": 1},
}
#: ``copy_info_dict``: the reward's unseen-marker term is read from each transition's info.
HER_KWARGS: dict[str, Any] = {
    "n_sampled_goal": 4,
    "goal_selection_strategy": "future",
    "copy_info_dict": True,
}
PPO_KWARGS: dict[str, Any] = {
    "n_steps": 512,
    "batch_size": 32,
    "gae_lambda": 0.9,
    "gamma": 0.9,
    "n_epochs": 20,
    "learning_rate": 1e-4,
    "clip_range": 0.3,
}
LEARNING_STARTS, LEARNING_STARTS_FRACTION = 1000, 0.05
#: One change each to the settings above (``"zoo"``: none), and the methods it applies to:
#: ``g2`` two gradient steps per env step, ``gamma0.5`` a discount for episodes of a few moves,
#: ``gamma0`` no bootstrapping at all (one-move episodes: the reward is the whole return).
VARIANTS: dict[str, dict[str, Any]] = {
    "zoo": {},
    "g2": {"train_freq": 1, "gradient_steps": 2},
    "gamma0.5": {"gamma": 0.5},
    "gamma0": {"gamma": 0.0},
}
VARIANT_METHODS: dict[str, tuple[str, ...]] = {
    "zoo": METHODS,
    "g2": ("sac_her", "sac", "sac_pixels"),
    "gamma0.5": ("sac_her", "sac"),
    "gamma0": ("sac_her", "sac"),
}
#: Image-based SAC (``sac_pixels``): both camera images (``obs_mode="pixels"``, no joint angles)
#: and the goal pixels; one NatureCNN per image shared by actor and critic (SB3 then trains it
#: through the critic only, as DrQ and SAC-AE do), a smaller batch: CNN gradient steps on a CPU
#: are costly (docs/decisions.md).
PIXEL_SAC_KWARGS: dict[str, Any] = {
    "batch_size": 64,
    "policy_kwargs": {**SAC_KWARGS["policy_kwargs"], "share_features_extractor": True},
}


@dataclass
class Curve:
    """One method, variant, episode length and seed: mean and median final distance (m) and the
    success fractions (keyed by :func:`success_key`) at each checkpoint."""

    method: str
    seed: int
    steps: list[int] = field(default_factory=list)
    mean_m: list[float] = field(default_factory=list)
    median_m: list[float] = field(default_factory=list)
    train_seconds: float = 0.0  # wall time spent training (evaluations excluded)
    variant: str = "zoo"
    episode_steps: int = MAX_EPISODE_STEPS
    success: dict[str, list[float]] = field(default_factory=dict)

    def add(self, steps: int, final: np.ndarray) -> None:
        self.steps.append(int(steps))
        self.mean_m.append(float(np.mean(final)))
        self.median_m.append(float(np.median(final)))
        for t in SUCCESS_THRESHOLDS:
            self.success.setdefault(success_key(t), []).append(float(np.mean(final < t)))

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def success_key(threshold: float) -> str:
    """``"5mm"`` for 0.005 m: the key of :attr:`Curve.success`."""
    return f"{threshold * 1e3:g}mm"


def checkpoints(budget: int, count: int) -> list[int]:
    """``count`` env-step counts, log-spaced, ending at ``budget``."""
    first = max(budget // 2 ** (count - 1), 1)
    points = np.unique(np.geomspace(first, budget, count).round().astype(int))
    return [int(p) for p in points]


def evaluate_policy(
    make_env: Callable[[], gym.Env],
    act: Callable[[dict], np.ndarray],
    targets: int,
    episode_steps: int = MAX_EPISODE_STEPS,
) -> np.ndarray:
    """Final ground-truth distance (m) of ``targets`` held-out episodes of ``episode_steps``
    moves, (targets,)."""
    env = make_env()
    seed_env(env, EVAL_SET, "evaluation")
    final = np.empty(targets)
    for i in range(targets):
        obs, info = env.reset()
        for _ in range(episode_steps):
            obs, _, _, _, info = env.step(act(obs))
        final[i] = info["distance"]
    env.close()
    return final


def _distance_now(env: gym.Env) -> float:
    """Ground-truth distance (m) of the env's current state (where a stopped trial stopped)."""
    base = env.unwrapped
    return math.dist(base.data.mocap_pos[base.target_mocap_id], base.sensed_point())


def evaluate_map(
    make_env: Callable[[], gym.Env], som, targets: int, episode_steps: int = MAX_EPISODE_STEPS
) -> np.ndarray:
    """Like :func:`evaluate_policy` for the map: the same targets, one coarse and
    ``episode_steps - 1`` fine moves per trial."""
    env = make_env()
    seed_env(env, EVAL_SET, "evaluation")
    final = np.empty(targets)
    for i in range(targets):
        run_trial(env, som, fine_moves=episode_steps - 1)
        final[i] = _distance_now(env)
    env.close()
    som.reset()
    return final


def train_map(
    env_id: str,
    env_kwargs: dict,
    seed: int,
    budget: int,
    points: list[int],
    targets: int,
    episode_steps: int = MAX_EPISODE_STEPS,
) -> Curve:
    """The visuomotor map (``envs.harness.training``'s trial: coarse + one exploring fine move),
    evaluated on episodes of ``episode_steps`` moves (its training does not depend on them)."""

    def make_env() -> gym.Env:
        return gym.make(env_id, **env_kwargs)

    env = make_env()
    env.reset(seed=seed)
    config = RunConfig(env=env_id, seed=seed, trials=max(budget // MAP_TRAIN_MOVES, 1))
    som = initial_grasp_map(config, env) if config.grasp else initial_map(config, env)
    curve, steps = Curve("map", seed, episode_steps=episode_steps), 0
    for point in points:
        start = time.perf_counter()
        while steps < point:
            trial = run_trial(env, som, fine_moves=MAP_TRAIN_MOVES - 1, explore=True)
            learn_from(som, trial)
            steps += len(trial.commands)
        curve.train_seconds += time.perf_counter() - start
        curve.add(steps, evaluate_map(make_env, som, targets, episode_steps))
    env.close()
    return curve


def train_sb3(
    method: str,
    env_id: str,
    env_kwargs: dict,
    seed: int,
    budget: int,
    points: list[int],
    targets: int,
    variant: str = "zoo",
    episode_steps: int = MAX_EPISODE_STEPS,
    store: Store | None = None,
) -> Curve:
    """SAC + HER, SAC, PPO or image-based SAC on the env with ``normalize=True`` (PPO also under
    VecNormalize, observations and rewards, as RL Zoo runs it on Reacher), in episodes of
    ``episode_steps`` moves.

    With a ``store`` the run is resumable: after training to each checkpoint the model (with
    its replay buffer or normalisation) is saved, after its evaluation the curve; a run found
    there continues from its last saved model, with the checkpoints already evaluated kept.
    """
    from stable_baselines3.common.env_util import make_vec_env

    kwargs = {**env_kwargs, "normalize": True, "max_episode_steps": episode_steps}
    if method == "sac_pixels":
        kwargs["obs_mode"] = "pixels"

    def make_env() -> gym.Env:
        return gym.make(env_id, **kwargs)

    venv = make_vec_env(env_id, n_envs=1, seed=seed, env_kwargs=kwargs)
    resumed = store.resume(method, venv) if store is not None else None
    if resumed is None:
        model, venv = build_sb3(method, variant, venv, seed, budget)
        curve = Curve(method, seed, variant=variant, episode_steps=episode_steps)
    else:
        model, venv, curve = resumed
        venv.seed(seed + model.num_timesteps)  # fresh training targets, not the first ones again

    def act(obs: dict) -> np.ndarray:
        if method == "ppo":
            obs = venv.normalize_obs(obs)
        return model.predict(obs, deterministic=True)[0]

    for point in points:
        if curve.steps and point <= curve.steps[-1]:
            continue  # evaluated before the run was interrupted
        start = time.perf_counter()
        if model.num_timesteps < point:
            model.learn(point - model.num_timesteps, reset_num_timesteps=False)
            curve.train_seconds += time.perf_counter() - start
            if store is not None:
                store.save_model(model, venv, curve.train_seconds)
        curve.add(model.num_timesteps, evaluate_policy(make_env, act, targets, episode_steps))
        if store is not None:
            store.save_curve(curve)
    venv.close()
    return curve


def build_sb3(method: str, variant: str, venv, seed: int, budget: int) -> tuple[Any, Any]:
    """A new SB3 model for ``method`` with ``variant``'s changes, and the vec env it trains on
    (PPO's wrapped in VecNormalize)."""
    from stable_baselines3 import PPO, SAC, HerReplayBuffer
    from stable_baselines3.common.vec_env import VecNormalize

    if variant not in VARIANTS or method not in VARIANT_METHODS[variant]:
        valid = [v for v in VARIANTS if method in VARIANT_METHODS[v]]
        raise ValueError(f"variant {variant!r} does not apply to {method}; valid: {valid}")
    change = VARIANTS[variant]
    if method == "ppo":
        settings = {**PPO_KWARGS, **change}
        venv = VecNormalize(venv, norm_obs=True, norm_reward=True, gamma=settings["gamma"])
        return PPO("MultiInputPolicy", venv, seed=seed, device="cpu", **settings), venv
    starts = min(LEARNING_STARTS, int(LEARNING_STARTS_FRACTION * budget))
    extra: dict[str, Any] = {}
    if method == "sac_her":
        extra = {"replay_buffer_class": HerReplayBuffer, "replay_buffer_kwargs": HER_KWARGS}
    elif method == "sac_pixels":
        extra = {**PIXEL_SAC_KWARGS, "buffer_size": budget}  # images: no larger than needed
    settings = {**SAC_KWARGS, **extra, **change}
    model = SAC(
        "MultiInputPolicy", venv, seed=seed, device="cpu", learning_starts=starts, **settings
    )
    return model, venv


def run_method(method: str, variant: str = "zoo", store: Store | None = None, **kwargs) -> Curve:
    """Train and evaluate one method and seed (keyword arguments of :func:`train_map`); SB3
    methods take a ``variant`` of :data:`VARIANTS` and a ``store`` that makes them resumable."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    if method == "map":
        if variant != "zoo":
            raise ValueError(f"variant {variant!r} does not apply to the map; valid: ['zoo']")
        return train_map(**kwargs)
    return train_sb3(method, variant=variant, store=store, **kwargs)


def steps_to_reach(curves: list[Curve], threshold: float) -> int | None:
    """First checkpoint at which the mean over seeds of the mean final distance is ≤ threshold
    (m), or None. Checkpoints are compared by position (every seed has the same list)."""
    means = np.mean([c.mean_m for c in curves], axis=0)
    below = np.flatnonzero(means <= threshold)
    return int(np.mean([c.steps[below[0]] for c in curves])) if below.size else None
