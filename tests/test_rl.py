"""The ``rl`` extra: Stable-Baselines3's ``check_env`` on every env and setting, and a short
SAC + HER run whose relabelled rewards come from the env's ``compute_reward``.

Skipped, with the reason, when the extra is not installed (``make test-rl`` installs it). The SB3
parts run in child processes that import torch before anything renders (see
``scripts/compare_rl.py``: Mesa's and triton's LLVMs clash), whatever this process has drawn.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from importlib.util import find_spec

import pytest

pytestmark = pytest.mark.skipif(
    find_spec("stable_baselines3") is None or find_spec("torch") is None,
    reason="the rl extra is not installed (pip install -e '.[rl]', or make test-rl)",
)
CHILD_TIMEOUT = 600.0  # s; the SB3 checks of every setting, twice, take a few minutes
TARGETS = 20  # held-out targets of the resume test
PRELUDE = "import torch, torch._dynamo\nimport json, warnings\nimport numpy as np\nimport envs\n"
#: SB3's and Gymnasium's advice for the default action space (radians, float64); ``normalize``
#: follows it.
ADVICE = ("symmetric and normalized", "we recommend using np.float32")


def _child(code: str) -> object:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    done = subprocess.run(
        [sys.executable, "-c", PRELUDE + textwrap.dedent(code)],
        env=env,
        capture_output=True,
        text=True,
        timeout=CHILD_TIMEOUT,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_sb3_check_env_on_every_env_and_setting():
    """On ``gym.make``'s env (its outer wrapper has ``compute_reward``) and on ``unwrapped``."""
    results = _child(
        """
        import gymnasium as gym
        from stable_baselines3.common.env_checker import check_env

        settings = []
        for env_id, extra in (("RiacsReach-v0", {}), ("PumaReach-v0", {}),
                              ("PumaReach-v0", {"joints": 6})):
            for sensing in ("render", "project"):
                for control in ("servo", "kinematic"):
                    settings.append((env_id, {"sensing": sensing, "control": control, **extra}))
        settings.append(("RiacsReach-v0", {"sensing": "project", "control": "servo",
                                           "normalize": True}))
        settings += [("PumaTrack-v0", {"sensing": s}) for s in ("project", "render")]
        settings += [("RiacsReach-v0", {"sensing": "project", "control": "kinematic",
                                        "obs_mode": mode}) for mode in ("pixels", "state_pixels")]
        out = []
        for env_id, kwargs in settings:
            made = gym.make(env_id, **kwargs)
            for env in (made, made.unwrapped):  # what gym.make returns, and the env inside
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    check_env(env, warn=True, skip_render_check=True)
                out.append([env_id, kwargs, sorted({str(w.message)[:200] for w in caught})])
            made.close()
        print(json.dumps(out))
        """
    )
    assert len(results) == 2 * 17
    for env_id, kwargs, messages in results:
        other = [m for m in messages if not any(a in m for a in ADVICE)]
        assert other == [], (env_id, kwargs)  # check_env raised nothing and warns of nothing else
        if kwargs.get("normalize"):
            assert messages == [], (env_id, kwargs)


def test_sac_her_learns_from_rewards_the_env_computes():
    """200 steps of SAC + HER (learning after 100); every sampled reward, relabelled or not, is
    the env's reward for its goals: compute_reward(info=None), minus the reach if the marker was
    not seen."""
    result = _child(
        """
        import gymnasium as gym
        from stable_baselines3 import SAC, HerReplayBuffer

        env = gym.make("RiacsReach-v0", sensing="project", control="kinematic")
        model = SAC("MultiInputPolicy", env, seed=0, device="cpu", learning_starts=100,
                    batch_size=64, replay_buffer_class=HerReplayBuffer,
                    replay_buffer_kwargs={"n_sampled_goal": 4, "copy_info_dict": True})
        model.learn(200)
        batch = model.replay_buffer.sample(256)
        base = env.unwrapped
        achieved = batch.next_observations["achieved_goal"].numpy()
        desired = batch.observations["desired_goal"].numpy()
        rewards = batch.rewards.numpy()[:, 0]
        seen = base.compute_reward(achieved, desired, None)
        buffer = model.replay_buffer
        stored = buffer.next_observations["achieved_goal"][: buffer.pos, 0]  # (n, 4) float32
        relabelled = (desired[:, None, :] == stored[None]).all(axis=-1).any(axis=1)
        print(json.dumps({"steps": model.num_timesteps, "gap": (seen - rewards).tolist(),
                          "reach": base.reach, "relabelled": int(relabelled.sum())}))
        """
    )
    assert result["steps"] == 200
    assert result["relabelled"] > 0  # precondition: HER replaced goals in this sample
    for gap in result["gap"]:  # float32 buffer: rewards are stored to ~1e-7 m
        assert gap == pytest.approx(0.0, abs=1e-6) or gap == pytest.approx(result["reach"], 1e-6)


def test_sac_on_images_with_a_cnn_policy():
    """200 steps of SAC with ``MultiInputPolicy`` on both camera images and the goals: SB3 gives
    each image its own CNN, and the images reach the replay buffer as the env made them (SB3
    transposes them to channel first)."""
    result = _child(
        """
        import gymnasium as gym
        from stable_baselines3 import SAC
        from stable_baselines3.common.torch_layers import NatureCNN

        env = gym.make("RiacsReach-v0", sensing="project", control="kinematic",
                       obs_mode="pixels")
        model = SAC("MultiInputPolicy", env, seed=0, device="cpu", learning_starts=100,
                    batch_size=16, buffer_size=400)
        model.learn(200)
        extractors = model.policy.actor.features_extractor.extractors
        buffer = model.replay_buffer
        probe = gym.make("RiacsReach-v0", sensing="project", control="kinematic",
                         obs_mode="pixels")
        first, _ = probe.reset(seed=0)
        print(json.dumps({
            "steps": model.num_timesteps,
            "cnn": sorted(k for k, m in extractors.items() if isinstance(m, NatureCNN)),
            "dtype": str(buffer.observations["pixels_left"].dtype),
            # SB3 stores images channel first (VecTransposeImage)
            "first_image_stored": bool(np.array_equal(np.moveaxis(
                buffer.observations["pixels_left"][0, 0], 0, -1), first["pixels_left"])),
        }))
        """
    )
    assert result["steps"] == 200
    assert result["cnn"] == ["pixels_left", "pixels_right"]
    assert result["dtype"] == "uint8"
    assert result["first_image_stored"]  # SAC seeds the env as this probe does


def test_each_variant_reaches_the_sb3_model():
    """The comparison's variants change what they say and nothing else: γ 0 and γ 0.5 the
    discount, g2 the gradient steps; every other setting stays RL Zoo's."""
    result = _child(
        """
        import gymnasium as gym
        from stable_baselines3.common.env_util import make_vec_env
        from envs.studies.rl_comparison import build_sb3

        kwargs = {"sensing": "project", "control": "kinematic", "normalize": True}
        seen = {}
        for variant in ("zoo", "g2", "gamma0.5", "gamma0"):
            venv = make_vec_env("RiacsReach-v0", n_envs=1, env_kwargs=kwargs)
            model, _ = build_sb3("sac", variant, venv, seed=0, budget=1000)
            seen[variant] = [model.gamma, model.gradient_steps, model.batch_size,
                             model.learning_rate]
        print(json.dumps(seen))
        """
    )
    zoo = [0.95, 1, 256, 1e-3]  # RL Zoo's her.yml
    assert result == {
        "zoo": zoo,
        "g2": [0.95, 2, 256, 1e-3],
        "gamma0.5": [0.5, 1, 256, 1e-3],
        "gamma0": [0.0, 1, 256, 1e-3],
    }


def test_an_interrupted_run_continues_where_it_stopped(tmp_path):
    """A run interrupted while evaluating its 2nd checkpoint (its model already saved), then run
    again: the checkpoints are those of an uninterrupted run, the first two bit for bit (the
    first kept from the file, the second the reloaded model's), no training step is repeated
    (the env steps of the second session are the remaining budget and the evaluations), and a
    finished run is not run again. Later checkpoints differ a little: the random generators and
    the training env's state are not saved (``envs.studies.rl_runs``)."""
    result = _child(
        f"""
        from pathlib import Path
        from envs.reach import ReachEnv
        from envs.studies import rl_comparison, rl_runs

        torch.set_num_threads(1)
        out, evaluate, step = Path({str(tmp_path)!r}), rl_comparison.evaluate_policy, ReachEnv.step
        counted = []
        def counting_step(self, action):
            counted.append(1)
            return step(self, action)
        ReachEnv.step = counting_step

        def interrupt_second(*args, **kwargs):
            interrupt_second.calls += 1
            if interrupt_second.calls == 2:
                raise KeyboardInterrupt
            return evaluate(*args, **kwargs)

        results = {{}}
        for method, points in (("sac_her", (100, 200, 400)), ("ppo", (512, 1024, 1536))):
            spec = rl_runs.RunSpec("RiacsReach-v0", "project", "kinematic", method, "zoo", 4, 0,
                                   points[-1], points, {TARGETS})
            whole = rl_runs.run(spec, out / "whole")
            interrupt_second.calls = 0
            rl_comparison.evaluate_policy = interrupt_second
            try:
                rl_runs.run(spec, out / "cut")
            except KeyboardInterrupt:
                pass
            rl_comparison.evaluate_policy = evaluate
            counted.clear()
            resumed = rl_runs.run(spec, out / "cut")
            second_session = len(counted)
            counted.clear()
            again = rl_runs.run(spec, out / "cut")
            results[method] = {{"whole": [whole.steps, whole.mean_m],
                               "resumed": [resumed.steps, resumed.mean_m],
                               "again": again.mean_m, "steps_again": len(counted),
                               "second_session": second_session}}
        print(json.dumps(results))
        """
    )
    for method, (first, last) in (("sac_her", (200, 400)), ("ppo", (1024, 1536))):
        r = result[method]
        assert r["resumed"][0] == r["whole"][0]  # the same checkpoints
        assert r["resumed"][1][:2] == r["whole"][1][:2], method  # bit for bit up to the save
        assert r["second_session"] == (last - first) + 2 * TARGETS * 4  # training + 2 evaluations
        assert r["again"] == r["resumed"][1] and r["steps_again"] == 0  # finished: not run again
        # the rest continues the same learning: close to the uninterrupted run, not equal
        assert r["resumed"][1][2] == pytest.approx(r["whole"][1][2], rel=0.5), method
