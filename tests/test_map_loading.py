"""Both maps' loaders check what a checkpoint holds as construction checks it: the bounds
(dtype, shape, finite, lower < upper, plausible), the generator's state (whatever numpy would
refuse or misread is a ``CheckpointError`` naming ``rng_state``), the learned arrays' ranges,
the fine-move memory, and settings beyond any plausible value; one shared set of checks words
each refusal alike for both maps, in one short line."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from test_checkpoint_fuzz import MESSAGE_LIMIT, pose_state, reach_state, same_map, trained_map

from learners import CheckpointError, VisuomotorSOM
from learners.persistence import save_npz
from learners.som.config import SOMConfig
from learners.som.hierarchical import HierarchicalSOM
from learners.som.hierarchical_config import HierarchicalConfig

#: The entries of a default Continual and of its monitor's state, as a checkpoint holds them.
CONTINUAL = {"fast": 0.02, "slow": 0.001, "trigger": 1.5, "rewind": 0.25, "readapt": 3000}
MONITOR = {"fast": 0.1, "reference": 0.1, "start": -1, "readaptations": 0}
LOADERS = {"VisuomotorSOM": VisuomotorSOM.load, "HierarchicalSOM": HierarchicalSOM.load}


def _refusal(tmp_path: Path, kind: str, change) -> str:
    """The one-line message with which the loader of ``kind`` refuses the saved map changed by
    ``change(config, arrays)`` (written with valid CRCs), the path cut out."""
    config, arrays = reach_state() if kind == "VisuomotorSOM" else pose_state()
    change(config, arrays)
    path = save_npz(tmp_path / f"{kind}.npz", kind, 1, config, arrays)
    with pytest.raises(CheckpointError) as refused:
        LOADERS[kind](path)
    text = str(refused.value)
    assert text.startswith(f"{path}: ") and "\n" not in text and "array(" not in text, text
    assert len(text) - len(str(path)) <= MESSAGE_LIMIT, text
    return text.removeprefix(f"{path}: ")


def _array(name, f):
    def change(config, arrays):
        arrays[name] = f(arrays[name])

    return change


def _entry(name, value):
    def change(config, arrays):
        config[name] = value

    return change


def _rng(where, key, value):
    def change(config, arrays):
        place = config["rng_state"] if where == "outer" else config["rng_state"]["state"]
        if value is KeyError:
            del place[key]
        else:
            place[key] = value

    return change


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_array("joint_upper", lambda a: a.view(np.int64)), "'joint_upper' is int64"),
        (_array("joint_upper", lambda a: a.astype(np.float32)), "'joint_upper' is float32"),
        (_array("joint_lower", lambda a: a.reshape(1, -1)), "not a float64 vector"),
        (_array("joint_upper", lambda a: a * 0 + 1e300), "beyond ±1e+09"),
        (_array("input_high", lambda a: a.astype(np.float32)), "'input_high' is float32"),
        (_array("input_low", lambda a: a * 0 - 1e300), "beyond ±1e+09"),
        (_array("input_high", lambda a: np.append(a, 1.0)), "must both have shape (4,)"),
    ],
)
def test_reach_map_refuses_stored_bounds_construction_would_not_take(tmp_path, change, message):
    assert message in _refusal(tmp_path, "VisuomotorSOM", change)


@pytest.mark.parametrize("kind", sorted(LOADERS))
@pytest.mark.parametrize(
    "change",
    [
        _rng("inner", "state", 2**200),  # OverflowError inside numpy
        _rng("outer", "uinteger", -5),  # OverflowError too
        _rng("outer", "has_uint32", 7),  # taken by numpy and kept
        _rng("inner", "inc", KeyError),
        _rng("outer", "bit_generator", "Philox"),  # a state of another layout
        _rng("outer", "bit_generator", "default_rng"),  # a numpy.random attribute, no generator
        _rng("inner", "inc", 4),  # even: no seeded PCG generator has it
    ],
)
def test_a_generator_state_numpy_would_choke_on_or_misread_is_refused(tmp_path, kind, change):
    assert "rng_state" in _refusal(tmp_path, kind, change)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_array("A", lambda a: a * 0 + 1e250), "beyond 1e+09 joint spans"),
        (_array("w_pos", lambda a: a * 1e6), "'w_pos' (18, 4) has entries outside"),
        (_array("w_ori", lambda a: a * 0 + 1e250), "'w_ori' (18, 8, 8) has entries outside"),
        (_array("df_cov", lambda a: a * 0 + 1e250), "'df_cov' (12, 12) has entries outside"),
        (_array("df_cov", lambda a: a + np.triu(np.ones_like(a), 1)), "not symmetric"),
        (_array("theta", lambda a: a * np.nan), "'theta' (18, 8, 6) holds NaN"),
        (_entry("orientation_gain", 1e300), "orientation_gain must be <= 1000"),
        (_entry("t_max", 10**400), "t_max must be a finite int"),  # OverflowError before
    ],
)
def test_pose_map_refuses_what_the_reach_map_refuses(tmp_path, change, message):
    assert message in _refusal(tmp_path, "HierarchicalSOM", change)


@pytest.mark.parametrize(
    "change",
    [
        _array("joint_upper", lambda a: a.astype(np.float32)),
        _array("joint_lower", lambda a: a + 1e3),  # lower above upper
        _rng("inner", "state", 2**200),
        _entry("t", 2**60),
        _entry("skipped", {"not_visible": 0, "small_dv": True}),
    ],
)
def test_both_loaders_word_a_shared_check_alike(tmp_path, change):
    """The checks live once (``learners/som/stored.py``): the same damage gets the same reason
    from both loaders (the values and shapes aside: the maps have 3 and 6 joints)."""
    reach, pose = (
        re.sub(r"\(\d+(, \d+)*,?\)|\d+", "#", _refusal(tmp_path, kind, change).split(" got ")[0])
        for kind in sorted(LOADERS, reverse=True)
    )
    assert reach.replace("VisuomotorSOM", "MAP") == pose.replace("HierarchicalSOM", "MAP")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_array("_u", lambda a: a * 0 + 1e300), "'_u' lies beyond the margin"),
        (_array("_seen_v", lambda a: a * 1e12), "'_seen_v' lies beyond the margin"),
        (_array("_cmd", lambda a: a + 2.0), "'_cmd' (3,) has entries outside the joint ranges"),
        (_array("_abar", lambda a: a * 0 + 1e250), "_abar has entries up to 1e+250"),
    ],
)
def test_fine_move_memory_is_checked_against_the_maps_box_ranges_and_limit(
    tmp_path, change, message
):
    assert message in _refusal(tmp_path, "VisuomotorSOM", change)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_entry("a_init", 1e250), "a_init must be <= 1000"),
        (_entry("t_max", 10**400), "t_max must be a finite int"),
        (_entry("t", 2**60), "t = 1152921504606846976 is not a count"),
        (_entry("continual", {**CONTINUAL, "readapt": 1.5}), "readapt must be an integer"),
        (_entry("continual_state", {**MONITOR, "readaptations": -1}), "readaptations = -1"),
        (_entry("continual_state", {**MONITOR, "fast": "x"}), "fast and reference are not"),
    ],
)
def test_settings_beyond_any_plausible_value_are_refused(tmp_path, change, message):
    assert message in _refusal(tmp_path, "VisuomotorSOM", change)


def test_construction_refuses_what_the_loaders_refuse():
    for options, message in (
        ({"a_init": 1e250}, "a_init must be <= 1000"),
        ({"t_max": 10**400}, "t_max must be a finite int"),
        ({"sigma": (1e300, 1.0)}, r"sigma must be <= 1e\+09"),
    ):
        with pytest.raises(ValueError, match=message):
            SOMConfig(**options)
    with pytest.raises(ValueError, match="orientation_gain must be <= 1000"):
        HierarchicalConfig(orientation_gain=1e300)
    with pytest.raises(ValueError, match=r"beyond ±1e\+09"):
        VisuomotorSOM(np.zeros(3), np.full(3, 1e300))
    with pytest.raises(ValueError, match=r"beyond ±1e\+09"):
        VisuomotorSOM(np.zeros(3), np.ones(3), input_high=np.full(4, 1e12))


def test_a_loaded_map_equals_the_saved_one(tmp_path):
    """The checks refuse nothing a map writes (a reference for the refusals above)."""
    som = trained_map()
    assert same_map(VisuomotorSOM.load(som.save(tmp_path / "reach.npz")), som)
