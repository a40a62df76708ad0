"""The checkpoint unit of a training run: one file, written atomically, that holds the map, where
the run stands, the env's full simulation state and random generator, and how many metrics rows
belong to it, and that says which robot, joints, sensing, image size and lattice it is for.

The unit is a map file (a :class:`~learners.som.controller.VisuomotorSOM` on the reach envs, a
:class:`~learners.som.hierarchical.HierarchicalSOM` on the grasp envs) with two more entries
(``run``: JSON, ``sim_state``: the MuJoCo integration state), so the map's own ``load(unit)``
reads it, and :func:`load_map` reads either kind.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from envs.grasp import GraspEnv
from envs.harness.run_state import shown
from learners.persistence import CheckpointError, load_npz, save_npz, stored_kind
from learners.som import hierarchical
from learners.som.controller import FORMAT_VERSION, KIND, VisuomotorSOM
from learners.som.hierarchical import HierarchicalSOM

Map = VisuomotorSOM | HierarchicalSOM
#: The maps a unit may hold: kind -> (class, format version).
MAP_KINDS: dict[str, tuple[type, int]] = {
    KIND: (VisuomotorSOM, FORMAT_VERSION),
    hierarchical.KIND: (HierarchicalSOM, hierarchical.FORMAT_VERSION),
}

#: The unit's file name in a run folder (the map file the scripts load) ...
CHECKPOINT_FILE = "checkpoint.npz"
#: ... and the name runs before it kept it under: those runs keep it (resume writes it back).
OLD_CHECKPOINT_FILE = "som.npz"
_RUN, _SIM = "run", "sim_state"
#: time, qpos, qvel, act, qacc_warmstart, ctrl, applied forces, mocap pose, ...: everything
#: mj_step reads, so that a restored simulation continues bit for bit.
SIM_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


def checkpoint_path(folder: str | os.PathLike) -> Path:
    """The checkpoint unit of the run folder ``folder``: ``checkpoint.npz``, or the ``som.npz``
    of a run written before the unit had that name (``checkpoint.npz`` when neither exists)."""
    folder = Path(folder)
    old = folder / OLD_CHECKPOINT_FILE
    new = folder / CHECKPOINT_FILE
    return old if old.is_file() and not new.is_file() else new


#: What a unit's identity records (:func:`identity`); units of the first releases hold the
#: image size as ``image_size`` = [height, width].
IDENTITY_KEYS = ("robot", "joints", "sensing", "width", "height", "lattice")
SIZE = ("width", "height")


def identity(env: Any, lattice: tuple[int, ...]) -> dict[str, Any]:
    """Robot, joints, sensing, image width and height (px) and lattice of a map on ``env``: what
    a checkpoint is for (a map is only meaningful on the env it was trained on)."""
    base = env.unwrapped
    return {
        "robot": base.robot,
        "joints": int(base.joints),
        "sensing": base.sensing,
        "width": int(base.image_width),
        "height": int(base.image_height),
        "lattice": [int(n) for n in lattice],
    }


def get_sim_state(env: Any) -> np.ndarray:
    """The env's MuJoCo integration state, (n,) float64."""
    base = env.unwrapped
    state = np.empty(mujoco.mj_stateSize(base.model, SIM_STATE))
    mujoco.mj_getState(base.model, base.data, state, SIM_STATE)
    return state


#: rad (m for a slide joint): a joint may lie this far outside its range in a saved state. The
#: simulator lets a servo move overshoot a limit: at most 0.0155 rad measured in any physics step
#: of 150 servo trials per robot (RIACS; PUMA 0.0061), 1.2e-5 rad after a trial, where states
#: are saved.
JOINT_RANGE_TOLERANCE = 0.05
#: rad/s: no joint of these arms moves this fast (the fastest measured in a servo move: 59 rad/s,
#: PUMA joint 6 mid-move; after a trial, where states are saved, below 1e-3 rad/s).
MAX_JOINT_SPEED = 1000.0
#: s: simulated time of a saved state is below this (episodes start at 0; a run of a million
#: trials of four 2 s moves each, its arm never reset, stays below 1e7 s) ...
MAX_SIM_TIME = 1e9
#: ... and a mocap body (target, object) lies within this distance of the origin (m; these
#: robots reach about 1 m).
MAX_MOCAP_DISTANCE = 100.0


def sim_state_parts(model: Any) -> dict[str, slice]:
    """The parts of a state from :func:`get_sim_state` (``"qpos"``, ``"qvel"``, ``"ctrl"``, ...:
    the ``mjSTATE_`` names, lower case) and where each lies in it (mj_getState writes them in
    the order of their bits)."""
    parts, at = {}, 0
    for name, bit in mujoco.mjtState.__members__.items():
        value = int(bit)
        if value & (value - 1) or not value & int(SIM_STATE):  # a group or not stored
            continue
        size = mujoco.mj_stateSize(model, bit)
        parts[name.removeprefix("mjSTATE_").lower()] = slice(at, at + size)
        at += size
    return parts


def check_sim_state(model: Any, state: np.ndarray) -> None:
    """Refuse a state that cannot be this model's: another size or dtype, numbers that are not
    finite, a time outside 0 .. MAX_SIM_TIME, a mocap body beyond MAX_MOCAP_DISTANCE, a joint
    beyond its range (more than JOINT_RANGE_TOLERANCE), a joint faster than MAX_JOINT_SPEED or
    a control outside its actuator's range.

    Raises:
        CheckpointError: naming the part and the joint or actuator.
    """
    size = mujoco.mj_stateSize(model, SIM_STATE)
    if not isinstance(state, np.ndarray) or state.shape != (size,) or state.dtype != np.float64:
        found = f"{state.dtype} {state.shape}" if isinstance(state, np.ndarray) else "not an array"
        raise CheckpointError(
            f"simulation state is {found}; this model's (nq {model.nq}, nv {model.nv}, na "
            f"{model.na}, nu {model.nu}) has {size} float64 numbers; the checkpoint is damaged "
            "or from another model"
        )
    parts = {name: state[at] for name, at in sim_state_parts(model).items()}
    for name, values in parts.items():
        if not np.isfinite(values).all():
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            raise CheckpointError(
                f"simulation state: {name}[{bad}] is {values[bad]}, not finite; the checkpoint "
                "is damaged"
            )
    time = parts["time"][0]
    if not 0 <= time <= MAX_SIM_TIME:
        raise CheckpointError(
            f"simulation state: time is {time:.6g} s, not in 0 .. {MAX_SIM_TIME:g} s; the "
            "checkpoint is damaged"
        )
    far = np.abs(parts["mocap_pos"])
    if far.size and far.max() > MAX_MOCAP_DISTANCE:
        raise CheckpointError(
            f"simulation state: mocap_pos[{int(far.argmax())}] is {far.max():.6g} m from the "
            f"origin, beyond {MAX_MOCAP_DISTANCE:g} m; the checkpoint is damaged"
        )
    for j in np.flatnonzero(model.jnt_limited):
        low, high = model.jnt_range[j]
        q = parts["qpos"][model.jnt_qposadr[j]]
        if not low - JOINT_RANGE_TOLERANCE <= q <= high + JOINT_RANGE_TOLERANCE:
            raise CheckpointError(
                f"simulation state: qpos of joint {model.joint(j).name!r} is {q:.6g}, outside "
                f"its range {low:.6g} .. {high:.6g} (tolerance {JOINT_RANGE_TOLERANCE}); the "
                "checkpoint is damaged or from another model"
            )
    speed = np.abs(parts["qvel"])
    if speed.size and speed.max() > MAX_JOINT_SPEED:
        dof = int(speed.argmax())
        raise CheckpointError(
            f"simulation state: qvel[{dof}] (joint {model.joint(model.dof_jntid[dof]).name!r}) "
            f"is {parts['qvel'][dof]:.6g}, faster than {MAX_JOINT_SPEED:g} rad/s; the checkpoint "
            "is damaged"
        )
    ctrl = parts["ctrl"]
    for a in np.flatnonzero(model.actuator_ctrllimited):
        low, high = model.actuator_ctrlrange[a]
        if not low - JOINT_RANGE_TOLERANCE <= ctrl[a] <= high + JOINT_RANGE_TOLERANCE:
            raise CheckpointError(
                f"simulation state: ctrl of actuator {model.actuator(a).name!r} is "
                f"{ctrl[a]:.6g}, outside its range {low:.6g} .. {high:.6g}; the checkpoint is "
                "damaged"
            )


def set_sim_state(env: Any, state: np.ndarray) -> None:
    """Restore a state from :func:`get_sim_state` (and recompute positions from it), checked
    first (:func:`check_sim_state`: CheckpointError, the simulation unchanged)."""
    base = env.unwrapped
    check_sim_state(base.model, state)
    mujoco.mj_setState(base.model, base.data, state, SIM_STATE)
    mujoco.mj_forward(base.model, base.data)


def _kind(path: str | os.PathLike) -> tuple[str, type, int]:
    """(kind, map class, format version) of the map file ``path`` (the reach map's when the
    file names no kind this code reads: loading it then says what is wrong)."""
    kind = stored_kind(path)
    kind = kind if kind in MAP_KINDS else KIND
    return (kind, *MAP_KINDS[kind])


def load_map(path: str | os.PathLike) -> Map:
    """The map of a map file or unit, of whichever kind it holds (CheckpointError if none)."""
    return _kind(path)[1].load(path)


def write_unit(
    path: str | os.PathLike, som: Map, run: dict[str, Any], sim_state: np.ndarray
) -> Path:
    """Write the map, ``run`` (JSON-able) and the simulation state to ``path`` atomically."""
    config, arrays = som.state()
    kind = KIND if isinstance(som, VisuomotorSOM) else hierarchical.KIND
    extra = {_RUN: np.array(json.dumps(run, sort_keys=True)), _SIM: sim_state}
    return save_npz(path, kind, MAP_KINDS[kind][1], config, {**arrays, **extra})


def read_unit(path: str | os.PathLike) -> tuple[dict[str, Any], np.ndarray]:
    """(run, simulation state) of a unit; CheckpointError for a plain map or a damaged file."""
    kind, _, version = _kind(path)
    return _unit(path, load_npz(path, kind, version)[1])


def _unit(path: str | os.PathLike, arrays: dict[str, Any]) -> tuple[dict[str, Any], np.ndarray]:
    """:func:`read_unit` of the arrays already loaded from ``path``."""
    if _RUN not in arrays:
        raise CheckpointError(f"{path}: a map without a training run's state; cannot resume it")
    if _SIM not in arrays:
        raise CheckpointError(f"{path}: the run's simulation state ({_SIM}) is missing; damaged")
    try:
        run = json.loads(str(arrays[_RUN]))
        if not isinstance(run, dict):
            raise TypeError(f"it is {type(run).__name__}, not a dict")
        missing = {"config", "identity", "trial"} - set(run)
    except (ValueError, TypeError) as exc:
        raise CheckpointError(f"{path}: the run's state is damaged ({exc})") from exc
    if missing:
        raise CheckpointError(f"{path}: the run's state lacks {sorted(missing)}; damaged file")
    return run, arrays[_SIM]


def read_identity(path: str | os.PathLike) -> dict[str, Any] | None:
    """The identity recorded in a unit, or None for a plain map file."""
    kind, _, version = _kind(path)
    _, arrays = load_npz(path, kind, version)
    if _RUN not in arrays:
        return None
    return unit_identity(_unit(path, arrays)[0], str(path))


def unit_identity(run: dict[str, Any], where: str = "the checkpoint") -> dict[str, Any]:
    """The identity recorded in a unit's ``run`` (from :func:`read_unit`); CheckpointError
    naming ``where`` if it is not a dict."""
    recorded = run.get("identity")
    if not isinstance(recorded, dict):
        raise CheckpointError(
            f"{where}: the run's identity is {shown(recorded)}, not a dict; the file is damaged"
        )
    recorded = dict(recorded)
    missing = [
        k
        for k in IDENTITY_KEYS
        if k not in recorded and not (k in SIZE and "image_size" in recorded)
    ]
    if missing:
        raise CheckpointError(
            f"{where}: the run's identity lacks {', '.join(missing)}; the file is damaged"
        )
    if "image_size" in recorded:  # written before sizes were width and height: [height, width]
        size = recorded.pop("image_size")
        if not isinstance(size, list) or len(size) != 2:
            raise CheckpointError(
                f"{where}: the run's identity has image_size {shown(size)}, not [height, width]; "
                "the file is damaged"
            )
        recorded["height"], recorded["width"] = size
    return recorded


def check_identity(
    path: str | os.PathLike, found: dict[str, Any], wanted: dict[str, Any], keys: tuple[str, ...]
) -> None:
    """CheckpointError naming both sides if ``found`` and ``wanted`` differ in any of ``keys``."""
    bad = [k for k in keys if found.get(k) != wanted.get(k)]
    if bad:
        ours = ", ".join(f"{k}={shown(found.get(k))}" for k in bad)
        theirs = ", ".join(f"{k}={shown(wanted.get(k))}" for k in bad)
        raise CheckpointError(
            f"{path} was trained for {ours}, but this env has {theirs}; use a checkpoint of "
            "this setting or choose the env it was trained on"
        )


def check_map_fits(path: str | os.PathLike, som: Map, env: Any) -> None:
    """Refuse a map trained for another robot, joint set or image size than ``env``'s.

    A unit names its robot, joints and image size; a plain map file is checked by its joint
    ranges, which differ between robots and joint sets. Sensing may differ (both give pixels).
    A grasp env (12 goal pixels) needs the hierarchical map, a reach env the reach map.
    """
    base = env.unwrapped
    pose = isinstance(base, GraspEnv)
    if pose != isinstance(som, HierarchicalSOM):
        wanted = "a HierarchicalSOM (pose)" if pose else "a VisuomotorSOM (reach)"
        raise CheckpointError(
            f"{path} holds a {type(som).__name__}, but this env needs {wanted} map; train one on "
            "this env with train.py"
        )
    recorded = read_identity(path)
    if recorded is not None:
        keys = ("robot", "joints", "width", "height")
        check_identity(path, recorded, identity(env, som.lattice), keys)
    lower, upper = base.learner_bounds() if pose else (base.joint_lower, base.joint_upper)
    if som.lower.shape != lower.shape or not (
        np.allclose(som.lower, lower) and np.allclose(som.upper, upper)
    ):
        raise CheckpointError(
            f"{path} was trained for joint ranges {np.round(som.lower, 3).tolist()} .. "
            f"{np.round(som.upper, 3).tolist()} rad, but this env ({base.robot}, {base.joints} "
            f"joints) has {np.round(lower, 3).tolist()} .. {np.round(upper, 3).tolist()}; use a "
            "map of this robot"
        )
