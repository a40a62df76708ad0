"""Damaged checkpoints of both map kinds (the reach map ``VisuomotorSOM`` and the grasp task's
``HierarchicalSOM``): random bytes anywhere (array data, ``.npy`` headers, the zip's local
headers and central directory) and truncations, then crafted damage written with valid CRCs
(arrays of another dtype or shape, NaN, inf, 1e300, bounds out of order, configuration entries
of a wrong type or range, generator states numpy would choke on). Every damaged file either
raises ``CheckpointError`` in one short line or loads a map identical to the one saved (every
array bit-equal, the same configuration and generator state): no other exception, no silently
different map. ``make soak`` (``VISUOMOTOR_SOAK=1``) runs ten times the cases of ``make test``.
"""

from __future__ import annotations

import copy
import functools
import io
import json
import math
import os
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from learners import CheckpointError, VisuomotorSOM
from learners.persistence import save_npz
from learners.som.hierarchical import HierarchicalSOM
from learners.som.schedules import Continual

from helpers import one_line_error, run_script

SOAK = bool(os.environ.get("VISUOMOTOR_SOAK"))
#: Damaged checkpoints of each map kind: random byte damage and truncation, crafted damage.
RANDOM_CASES = 1000 if SOAK else 100
CRAFTED_CASES = 1000 if SOAK else 100
#: A refusal is one line of at most this many characters besides the file's path.
MESSAGE_LIMIT = 200

State = tuple[dict[str, Any], dict[str, np.ndarray]]


def trained_map() -> VisuomotorSOM:
    """A small reach map that has learned from a few random trials (arrays away from their
    start), in the continual mode with recovery (so that its checkpoint holds the monitor and
    every field of the fine-move memory)."""
    rng = np.random.default_rng(5)
    som = VisuomotorSOM(
        np.zeros(3), np.ones(3), lattice=(3, 3, 2), input_dim=4, rng=1, continual=Continual(),
        recover=True,
    )  # fmt: skip
    for _ in range(20):
        u, v0, v1 = rng.uniform(0.2, 0.8, (3, 4))
        theta0 = som.act(u)
        theta1 = som.act(u, v0, explore=True)
        som.learn(u, theta0, v0, theta1, v1)
    return som


def trained_pose_map() -> HierarchicalSOM:
    """A small grasp map trained on 60 objects (as tests/test_hierarchical_som.py does)."""
    from envs.studies.grasp_learning import train
    from envs.studies.grasp_oracle import PoseOracle
    from models.puma560.grasp import READY
    from models.puma560.kinematics import DH

    som = HierarchicalSOM(
        DH.lower, DH.upper, READY, rng=0, position_lattice=(3, 3, 2),
        orientation_lattice=(2, 2, 2), t_max=800,
    )  # fmt: skip
    train(som, PoseOracle(), 60, np.random.default_rng(1))
    return som


def _copy(state: State) -> State:
    return copy.deepcopy(state[0]), {k: v.copy() for k, v in state[1].items()}


@functools.cache
def _reach_state() -> State:
    return _copy(trained_map().state())


@functools.cache
def _pose_state() -> State:
    return _copy(trained_pose_map().state())


def reach_state() -> State:
    """(configuration, arrays) of :func:`trained_map`, a copy to change."""
    return _copy(_reach_state())


def pose_state() -> State:
    """(configuration, arrays) of :func:`trained_pose_map`, a copy to change."""
    return _copy(_pose_state())


def save_npz_bytes(kind: str, config: dict[str, Any], arrays: dict[str, np.ndarray]) -> bytes:
    """The file ``save_npz`` writes, in memory."""
    buffer = io.BytesIO()
    stored = {**config, "__arrays__": sorted(arrays)}
    np.savez(
        buffer, __kind__=np.array(kind), __format_version__=np.array(1),
        __config__=np.array(json.dumps(stored, sort_keys=True)), **arrays,
    )  # fmt: skip
    return buffer.getvalue()


#: kind -> (the saved map's state, its loader, its checkpoint kind)
KINDS: dict[str, tuple[Callable[[], State], Callable[[Path], Any], str]] = {
    "reach": (reach_state, VisuomotorSOM.load, "VisuomotorSOM"),
    "pose": (pose_state, HierarchicalSOM.load, "HierarchicalSOM"),
}


def same_state(a: State, b: State) -> bool:
    """Whether two maps' states are identical: the configuration's JSON text (types included:
    1 is not 1.0 or true), the arrays' names, dtypes, shapes and bytes."""
    (ca, xa), (cb, xb) = a, b
    return (
        json.dumps(ca, sort_keys=True) == json.dumps(cb, sort_keys=True)
        and xa.keys() == xb.keys()
        and all(
            x.dtype == xb[k].dtype and x.shape == xb[k].shape and x.tobytes() == xb[k].tobytes()
            for k, x in xa.items()
        )
    )


def same_map(a: Any, b: Any) -> bool:
    return same_state(a.state(), b.state())


# ------------------------------------------------------------------------- random byte damage
def structure_offsets(blob: bytes) -> np.ndarray:
    """Byte offsets of the zip structure: each member's local header (30 bytes and its name) and
    the central directory to the end of the file."""
    with zipfile.ZipFile(io.BytesIO(blob)) as archive:
        spans = [
            range(i.header_offset, i.header_offset + 30 + len(i.filename))
            for i in archive.infolist()
        ]
        spans.append(range(archive.start_dir, len(blob)))
    return np.concatenate([np.array(s) for s in spans])


def damage(blob: bytes, rng: np.random.Generator, structure: np.ndarray) -> bytes:
    data = bytearray(blob)
    kind = rng.integers(3)
    if kind == 0:  # truncation
        return bytes(data[: rng.integers(len(data))])
    places = structure if kind == 1 else np.arange(len(data))
    for at in rng.choice(places, size=rng.integers(1, 5)):
        data[at] = (data[at] + rng.integers(1, 256)) % 256  # always a different byte
    return bytes(data)


# ------------------------------------------------------------------------- crafted damage
#: Values no configuration entry takes (each is of a wrong type or out of range for every
#: entry of both maps; ``{}`` is the default of ``continual``, which the reach map uses).
BAD_VALUES: tuple[Any, ...] = (
    None, "x", -1, 1e300, -1e300, 10**400, math.nan, math.inf, [], [0], [1e300], {}, 2**200,
)  # fmt: skip
BAD_SCHEDULES: tuple[Any, ...] = (
    [-1, 1], [1e300, 1], [math.nan, 1], [1, 2, 3], "x", [0, 1], [1, -1], None, [True, 1], [],
)  # fmt: skip
BAD_CONTINUAL: tuple[Any, ...] = ("x", None, -1, 1e300, math.nan, 10**400, [], True)
BAD_MEANS: tuple[Any, ...] = ("x", None, True, 1e300, math.nan, 5, math.inf)
BAD_COUNTS: tuple[Any, ...] = (-1, -2, 2**60, 10**400, 1.0, "3", True, None, [1])
#: Bit generator names a saved map may not give: other numpy generators (whose states a JSON
#: entry cannot hold), numpy.random attributes that are no generator, nonsense.
BAD_GENERATORS: tuple[Any, ...] = ("Philox", "MT19937", "SFC64", "default_rng", "x", None, 7)
BAD_GENERATOR_INTS: tuple[Any, ...] = (2**200, -1, -5, "x", 1.5, None, True, [1], 2**128)
#: Optional arrays (the fine-move memory): a missing one is a memory that was not set, so only
#: the required arrays are deleted.
OPTIONAL_ARRAYS = ("_u", "_cmd", "_abar", "_v", "_cmd_before", "_seen_cmd", "_seen_v")
BOUND_PAIRS = (("joint_lower", "joint_upper"), ("input_low", "input_high"))
DTYPES = ("float32", "int64", ">f8", "complex128", "bool", "float16", "<U8", "object", "view")


def _pick(rng: np.random.Generator, items: Any) -> Any:
    items = list(items)
    return items[int(rng.integers(len(items)))]


def _array_damage(arrays: dict[str, np.ndarray], rng: np.random.Generator) -> str:
    name = _pick(rng, sorted(arrays))
    a = arrays[name].copy()
    how = _pick(rng, ("dtype", "shape", "value", "missing"))
    if how == "missing" and name not in OPTIONAL_ARRAYS:
        del arrays[name]
        return f"{name} deleted"
    if how == "dtype":
        dtype = _pick(rng, DTYPES)
        arrays[name] = a.view(np.int64) if dtype == "view" else a.astype(dtype)
        return f"{name} as {dtype}"
    if how == "shape":
        shapes = {
            "flat": lambda: a.reshape(-1) if a.ndim > 1 else a.reshape(1, -1),
            "short": lambda: a[:-1],
            "long": lambda: np.concatenate([a, a[:1]]),
            "axis": lambda: a[..., None],
            "scalar": lambda: np.array(a.ravel()[0]),
            "empty": lambda: np.zeros((0,)),
        }
        change = _pick(rng, shapes)
        arrays[name] = shapes[change]()
        return f"{name} {change} {arrays[name].shape}"
    flat = a.reshape(-1)
    if name == "df_cov" and rng.integers(2):
        a[0, 1] += 1.0  # no longer symmetric
        arrays[name] = a
        return "df_cov asymmetric"
    value = _pick(rng, (math.nan, math.inf, -math.inf, 1e300, -1e300, "scale"))
    if value == "scale":
        arrays[name] = a * 1e12  # beyond every bound and box (zeros stay: then identical)
    else:
        flat[int(rng.integers(flat.size))] = value
        arrays[name] = a
    return f"{name} with {value}"


def _bounds_damage(arrays: dict[str, np.ndarray], rng: np.random.Generator) -> str:
    low, high = _pick(rng, [p for p in BOUND_PAIRS if p[0] in arrays])
    how = _pick(rng, ("swapped", "equal", "one equal"))
    if how == "swapped":
        arrays[low], arrays[high] = arrays[high].copy(), arrays[low].copy()
    elif how == "equal":
        arrays[high] = arrays[low].copy()
    else:
        i = int(rng.integers(len(arrays[low])))
        arrays[high] = arrays[high].copy()
        arrays[high][i] = arrays[low][i]
    return f"{low}/{high} {how}"


def _entry_damage(config: dict[str, Any], rng: np.random.Generator) -> str:
    key = _pick(rng, sorted(config))
    value = _pick(rng, BAD_VALUES)
    config[key] = value
    return f"entry {key} = {str(value)[:20]}"


def _nested_damage(config: dict[str, Any], rng: np.random.Generator) -> str:
    key = _pick(rng, [k for k in ("schedules", "continual", "continual_state", "skipped", "t")
                      if k in config])  # fmt: skip
    if key == "t":
        config["t"] = _pick(rng, BAD_COUNTS)
        return f"t = {config['t']!r:.20}"
    entry = config[key]
    name = _pick(rng, sorted(entry))
    how = _pick(rng, ("value", "value", "value", "extra", "missing"))
    if how == "extra":
        entry["extra"] = 1
    elif how == "missing" and key != "continual":  # a missing Continual field is its default
        del entry[name]
    else:
        bad = {"schedules": BAD_SCHEDULES, "continual": BAD_CONTINUAL, "skipped": BAD_COUNTS}
        if key == "continual_state":
            start = ("x", None, True, 1.0, -2, 2**60, 10**400, config["t"] + 1)
            bad[key] = BAD_MEANS if name in ("fast", "reference") else start
        entry[name] = _pick(rng, bad[key])
        how = f"= {entry[name]!r:.20}"
    return f"{key}[{name}] {how}"


def _generator_damage(config: dict[str, Any], rng: np.random.Generator) -> str:
    state = config["rng_state"]
    how = _pick(rng, ("name", "int", "int", "missing", "extra", "even", "inner"))
    if how == "name":
        state["bit_generator"] = _pick(rng, BAD_GENERATORS)
        return f"rng_state named {state['bit_generator']!r}"
    if how == "int":
        place, key = _pick(rng, ((state, "has_uint32"), (state, "uinteger"),
                                 (state["state"], "state"), (state["state"], "inc")))  # fmt: skip
        place[key] = _pick(rng, BAD_GENERATOR_INTS + ((7, 2) if key == "has_uint32" else ()))
        return f"rng_state {key} = {place[key]!r:.20}"
    if how == "missing":
        place = _pick(rng, (state, state["state"]))
        del place[_pick(rng, sorted(place))]
        return "rng_state lacks a key"
    if how == "extra":
        _pick(rng, (state, state["state"]))["extra"] = 1
        return "rng_state has an extra key"
    if how == "even":
        state["state"]["inc"] -= 1  # PCG's increment is odd
        return "rng_state even increment"
    state["state"] = _pick(rng, ([1, 2], None, 5, "x"))
    return f"rng_state's state = {state['state']!r}"


def crafted(state: State, rng: np.random.Generator) -> tuple[str, State]:
    """A copy of ``state`` with one piece of damage (which, and where, drawn from ``rng``)."""
    config, arrays = _copy(state)
    how = _pick(rng, ("array", "array", "bounds", "entry", "nested", "generator"))
    if how == "array":
        what = _array_damage(arrays, rng)
    elif how == "bounds":
        what = _bounds_damage(arrays, rng)
    elif how == "entry":
        what = _entry_damage(config, rng)
    elif how == "nested":
        what = _nested_damage(config, rng)
    else:
        what = _generator_damage(config, rng)
    return what, (config, arrays)


def _check_refusal(exc: CheckpointError, path: Path) -> str | None:
    """What is wrong with a refusal's message, or None."""
    text = str(exc)
    if str(path) not in text:
        return f"does not name the file: {text[:100]}"
    if "\n" in text or len(text) - len(str(path)) > MESSAGE_LIMIT or "array(" in text:
        return f"not one short line ({len(text)} chars): {text[:300]!r}"
    return None


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_damaged_checkpoint_is_refused_or_loads_identically(tmp_path: Path, kind: str):
    make_state, load, stored_kind = KINDS[kind]
    saved = make_state()
    blob = save_npz_bytes(stored_kind, *saved)
    path = tmp_path / "checkpoint.npz"
    path.write_bytes(blob)
    assert same_state(load(path).state(), saved)  # the undamaged file loads as saved
    structure = structure_offsets(blob)
    rng = np.random.default_rng(2024)
    counts = {"random": [0, 0], "crafted": [0, 0]}  # refused, identical
    failures: list[str] = []
    for case in range(RANDOM_CASES + CRAFTED_CASES):
        path = tmp_path / f"damaged_{case}.npz"
        if case < RANDOM_CASES:
            group, what = "random", "random bytes"
            path.write_bytes(damage(blob, rng, structure))
        else:
            group = "crafted"
            what, (config, arrays) = crafted(saved, rng)
            save_npz(path, stored_kind, 1, config, arrays)
        try:
            loaded = load(path)
        except CheckpointError as exc:
            problem = _check_refusal(exc, path)
            if problem is not None:
                failures.append(f"case {case} ({what}): {problem}")
            counts[group][0] += 1
        except Exception as exc:  # a traceback where one line is promised
            failures.append(f"case {case} ({what}): {type(exc).__name__}: {str(exc)[:100]}")
        else:
            if same_state(loaded.state(), saved):
                counts[group][1] += 1
            else:
                failures.append(f"case {case} ({what}): loaded a different map")
        path.unlink()
    cases = RANDOM_CASES + CRAFTED_CASES
    refused = counts["random"][0] + counts["crafted"][0]
    identical = counts["random"][1] + counts["crafted"][1]
    print(
        f"{kind} map ({stored_kind}): {cases} damaged checkpoints, {refused} refused, "
        f"{identical} loaded identically, {len(failures)} failures; random bytes "
        f"{RANDOM_CASES} ({counts['random'][0]} refused, {counts['random'][1]} identical), "
        f"crafted {CRAFTED_CASES} ({counts['crafted'][0]} refused, {counts['crafted'][1]} "
        "identical)"
    )
    assert not failures, f"{len(failures)} failures, the first: " + "; ".join(failures[:5])
    assert counts["random"][0] > RANDOM_CASES // 2  # the damage was real: most of it is caught
    assert counts["crafted"][0] > 0.9 * CRAFTED_CASES  # identical only where nothing changed


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("compress_type", zipfile.ZIP_DEFLATED, "compressed or encrypted"),
        ("compress_type", zipfile.ZIP_LZMA, "compressed or encrypted"),
        ("flag_bits", 0x1, "compressed or encrypted"),
    ],
)
def test_members_save_never_writes_are_refused_by_name(tmp_path, field, value, message):
    """The zip directory's compression method and encryption flag, rewritten with valid CRCs:
    formats ``save`` never writes are refused, not handed to a decompressor."""
    som = trained_map()
    som.save(tmp_path / "checkpoint.npz")
    with (
        zipfile.ZipFile(tmp_path / "checkpoint.npz") as src,
        zipfile.ZipFile(tmp_path / "bad.npz", "w") as dst,
    ):
        for info in src.infolist():
            payload = src.read(info)
            if field == "compress_type":
                dst.writestr(info.filename, payload, compress_type=value)
            else:
                dst.writestr(info, payload)
    if field == "flag_bits":  # set the flag in every central directory entry by hand
        raw = bytearray((tmp_path / "bad.npz").read_bytes())
        at = raw.find(b"PK\x01\x02")
        while at >= 0:
            raw[at + 8] |= value
            at = raw.find(b"PK\x01\x02", at + 4)
        (tmp_path / "bad.npz").write_bytes(bytes(raw))
    with pytest.raises(CheckpointError, match=message):
        VisuomotorSOM.load(tmp_path / "bad.npz")


def crafted_file(tmp_path: Path, change) -> Path:
    """The saved reach map with ``change(config, arrays)`` applied, written with valid CRCs."""
    config, arrays = reach_state()
    change(config, arrays)
    return save_npz(tmp_path / "crafted.npz", "VisuomotorSOM", 1, config, arrays)


def _huge_lattice(config, arrays):
    config["lattice"] = [100_000] * 3  # w stays small: no allocation may follow the lattice


def _absurd_a(config, arrays):
    arrays["A"] = arrays["A"] * 0 + 1e250  # finite, but beyond anything a trial can teach


def _negative_t(config, arrays):
    config["t"] = -3


def _unknown_protocol(config, arrays):
    config["protocol"] = "hebb"


@pytest.mark.parametrize("change", [_huge_lattice, _absurd_a, _negative_t, _unknown_protocol])
def test_crafted_settings_with_valid_crcs_are_refused(tmp_path, change):
    with pytest.raises(CheckpointError) as refused:
        VisuomotorSOM.load(crafted_file(tmp_path, change))
    assert "\n" not in str(refused.value)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("env", "Pendulum-v1", "env is 'Pendulum-v1'"),
        ("eval_trials", -3, "eval_trials is -3"),
        ("lattice", [100_000, 100_000, 100_000], "the map's arrays"),
        ("protocol", "hebb", "protocol"),
    ],
)
def test_a_run_with_crafted_settings_is_refused_by_resume_and_evaluate(
    tmp_path, field, value, message
):
    """A training run's stored configuration passes the same guards as the command line:
    ``train.py --resume`` and ``evaluate.py --run`` end in one line, before any work."""
    from envs.harness.checkpoint import read_unit, write_unit
    from envs.harness.training import RunConfig, Trainer

    out = tmp_path / "run"
    Trainer(RunConfig.of(trials=1, lattice=(2, 2, 2), eval_every=1, eval_trials=2), out).close()
    path = out / "checkpoint.npz"
    run, sim_state = read_unit(path)
    write_unit(path, VisuomotorSOM.load(path), {**run, "config": {**run["config"], field: value}},
               sim_state)  # fmt: skip
    for script, args in (
        ("train", ["--out", str(out), "--resume"]),
        ("evaluate", ["--run", str(out)]),
    ):
        line = one_line_error(run_script(script, *args, "--targets", "2") if script == "evaluate"
                              else run_script(script, *args))  # fmt: skip
        assert "damaged" in line or message in line, line
