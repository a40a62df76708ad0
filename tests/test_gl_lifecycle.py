"""Envs dropped without ``close()`` leave the other envs of the process rendering as before.

Each back-end runs in a fresh interpreter (MuJoCo loads one GL back-end per process). There,
rendering envs of both robots and both rendered sensing modes are made and dropped in an order
drawn from a seeded generator, by ``del``, by rebinding the name to a new env, by ``close()`` and
by dropping a controller that held the env's ``stereo.triangulate``; after every drop each
survivor is reset with a new seed (and one of them just before the drop, so that its context is
current). What it senses (target and effector pixels, NaN where not seen)
must equal, bit for bit, what a fresh env senses after a reset with the same seed, and dropping
an env must leave current the GL context that was current before.
"""

from __future__ import annotations

import ctypes.util
import json
import os
import subprocess
import sys

import numpy as np
import pytest

SUBPROCESS_TIMEOUT = 300  # s
N_ENVS = 6  # made at the start; rebinding makes more
N_DROPS = 6  # at least one of each way
SEED = 24

_SCRIPT = r"""
import gc, json, sys
import numpy as np
import gymnasium as gym
import envs

args = json.loads(sys.argv[1])
backend = args["backend"]
rng = np.random.default_rng(args["seed"])
SPECS = [(i, s) for i in ("RiacsReach-v0", "PumaReach-v0") for s in ("render", "foveated")]
WAYS = ["del", "rebind", "close", "controller"]


def current_context():
    # The raw handle of the GL context current in this thread (0: none).
    if backend == "egl":
        from mujoco.egl import egl_ext as EGL
        handle = EGL.eglGetCurrentContext()
    else:
        from OpenGL import osmesa
        handle = osmesa.OSMesaGetCurrentContext()
    return handle.address if handle else 0


def sensed(env):
    u = env.unwrapped
    return np.concatenate([u.sensed_target(), u.sensed_effector()]).tolist()


class Controller:
    # A learner that keeps the rig's triangulation, as the exact baselines do.
    def __init__(self, triangulate):
        self.triangulate = triangulate


def make(spec):
    return spec, gym.make(SPECS[spec][0], sensing=SPECS[spec][1])


slots = {int(k): make(int(k) % len(SPECS)) for k in rng.permutation(args["n_envs"])}
readings = []  # (spec, seed, sensed) of every survivor's reset


def reset(k):
    spec, env = slots[k]
    seed = int(rng.integers(2**31))
    env.reset(seed=seed)
    readings.append((spec, seed, sensed(env)))


def reset_survivors():
    for k in rng.permutation(sorted(slots)).tolist():
        reset(k)


reset_survivors()
extra = rng.integers(len(WAYS), size=args["n_drops"] - len(WAYS)).tolist()
ways = [WAYS[i] for i in rng.permutation(list(range(len(WAYS))) + extra)]
kept_current = []
for way in ways:
    k = int(rng.choice(sorted(slots)))
    reset(int(rng.choice(sorted(set(slots) - {k}))))  # another env's context is current
    before = current_context()
    if way == "del":
        del slots[k]
    elif way == "rebind":  # the name now holds a new env of another kind
        slots[k] = make(int(rng.integers(len(SPECS))))
    elif way == "close":
        slots.pop(k)[1].close()
    else:
        controller = Controller(slots[k][1].unwrapped.stereo.triangulate)
        del slots[k]
        gc.collect()
        del controller
    gc.collect()
    kept_current.append(current_context() == before)
    reset_survivors()

fresh = [make(spec)[1] for spec in range(len(SPECS))]
references = []
for spec, seed, _ in readings:
    fresh[spec].reset(seed=seed)
    references.append(sensed(fresh[spec]))
out = {"readings": readings, "references": references, "ways": ways,
       "kept_current": kept_current}
with open(args["out"], "w") as f:
    json.dump(out, f)
"""


def _run(backend: str, tmp_path) -> dict:
    """The script's results in a fresh interpreter with MUJOCO_GL=backend."""
    out = tmp_path / f"{backend}.json"
    args = {"backend": backend, "seed": SEED, "n_envs": N_ENVS, "n_drops": N_DROPS}
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    result = subprocess.run(
        [sys.executable, "-c", _SCRIPT, json.dumps({**args, "out": str(out)})],
        env={**env, "MUJOCO_GL": backend},
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=SUBPROCESS_TIMEOUT,
    )
    assert result.returncode == 0, f"MUJOCO_GL={backend} failed:\n{result.stderr[-2000:]}"
    return json.loads(out.read_text())


@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_dropped_envs_leave_the_others_sensing_as_fresh_ones(backend, tmp_path):
    library = {"egl": "EGL", "osmesa": "OSMesa"}[backend]
    if ctypes.util.find_library(library) is None:
        reason = f"lib{library} is not installed"
        print(f"skipping MUJOCO_GL={backend}: {reason}")
        pytest.skip(reason)
    result = _run(backend, tmp_path)
    assert set(result["ways"]) == {"del", "rebind", "close", "controller"}
    assert result["kept_current"] and all(result["kept_current"]), result["ways"]
    readings, references = result["readings"], result["references"]
    assert len(readings) == len(references) > N_ENVS
    seen = 0
    for (spec, seed, got), want in zip(readings, references, strict=True):
        got, want = np.array(got), np.array(want)
        assert got.tobytes() == want.tobytes(), f"spec {spec} seed {seed}: {got} != {want}"
        seen += int(np.isfinite(want[:4]).all())
    assert seen >= len(readings) // 2, "too few targets seen for the comparison to mean much"
