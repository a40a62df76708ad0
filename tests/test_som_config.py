"""The map's options: SOMConfig (checks, checkpoint round trip), ``with_config`` on a learned map
against a map built with the option, read-only options, and ``evaluate.py --protocol`` on a
loaded map moving as the protocol it names."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from envs.cli import evaluate, train
from learners.som.config import ABAR, PROTOCOLS, SCHEDULES, THETA_TARGETS, SOMConfig, run_options
from learners.som.controller import VisuomotorSOM, kernels
from learners.som.hierarchical_config import HierarchicalConfig
from learners.som.schedules import Continual, Schedule
from models.riacs import LOWER, UPPER

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
IMAGE = np.array([320.0, 240.0, 320.0, 240.0])  # px
KERNELS = ["numpy", *(["numba"] if kernels.available() else [])]
#: Every option evaluate.py or adapt.py changes on a loaded map, each to a value other than the
#: trained map's (defaults: protocol "mrs", abar "local-fit", refine True).
CHANGES = [{"protocol": "brause"}, {"abar": "average"}, {"refine": False}, {"recover": True}]


def _inputs(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    U = rng.uniform(0.0, IMAGE, size=(n, 4))
    return U, U + rng.normal(0.0, 5.0, U.shape), U + rng.normal(0.0, 1.0, U.shape)


def _trained(kernel: str) -> VisuomotorSOM:
    som = VisuomotorSOM(LOWER, UPPER, t_max=200, rng=3, input_high=IMAGE, kernel=kernel)
    for u, v0, v1 in zip(*_inputs(300, 0), strict=True):
        som.reset()
        theta0, theta1 = som.act(u), som.act(u, v0, explore=True)
        som.learn(u, theta0, v0, theta1, v1)
    return som


def _moves(som: VisuomotorSOM) -> np.ndarray:
    """Coarse and two fine commands for 300 targets with fixed sensed values, (300, 3, J)."""
    out = []
    for u, v0, v1 in zip(*_inputs(300, 1), strict=True):
        som.reset()
        out.append([som.act(u), som.act(u, v0), som.act(u, v1)])
    return np.array(out)


def test_evaluate_changes_only_the_options_checked_here():
    args = argparse.Namespace(protocol="brause", no_refine=True, abar="local-fit", recover=True)
    changed = evaluate.som_changes(args)
    assert changed == {"protocol": "brause", "refine": False, "abar": "local-fit", "recover": True}
    assert set(changed) == {k for change in CHANGES for k in change}
    args = argparse.Namespace(protocol=None, no_refine=True, abar=None, recover=False)
    assert evaluate.som_changes(args) == {"refine": False, "abar": "average"}
    none = argparse.Namespace(protocol=None, no_refine=False, abar=None, recover=False)
    assert evaluate.som_changes(none) == {}


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("change", CHANGES, ids=lambda c: next(iter(c)))
def test_with_config_on_a_loaded_map_moves_as_a_map_built_with_the_option(kernel, change, tmp_path):
    trained = _trained(kernel)
    trained.save(tmp_path / "map.npz")
    changed = VisuomotorSOM.load(tmp_path / "map.npz", kernel=kernel).with_config(**change)
    built = VisuomotorSOM(LOWER, UPPER, t_max=200, rng=9, input_high=IMAGE, kernel=kernel,
                          **change)  # fmt: skip
    built.w, built.theta, built.A = trained.w, trained.theta, trained.A
    built.t = trained.t
    assert changed.config == built.config and changed.kernel == built.kernel == kernel
    np.testing.assert_array_equal(_moves(changed), _moves(built))


def test_with_config_keeps_the_learned_state_and_refuses_shape_options():
    som = VisuomotorSOM(LOWER, UPPER, rng=1, input_high=IMAGE, continual=Continual())
    u, v0, v1 = (x[0] for x in _inputs(1, 2))
    theta0, theta1 = som.act(u), som.act(u, v0, explore=True)
    som.learn(u, theta0, v0, theta1, v1)
    other = som.with_config(abar="average", eps=(0.5, 0.01))
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(other, name), getattr(som, name))
    assert (other.t, other.skipped) == (som.t, som.skipped) == (1, {"not_visible": 0,
                                                                    "small_dv": 0})  # fmt: skip
    assert other.rng.bit_generator.state == som.rng.bit_generator.state
    assert other.rng.normal() == som.rng.normal()  # a copy of the generator, not the same one
    assert other.monitor.state() == som.monitor.state() and other.monitor is not som.monitor
    assert som.with_config(continual=Continual()).monitor.state()["readaptations"] == 0
    assert np.isnan(som.with_config(continual=Continual()).monitor.state()["fast"])  # fresh
    assert som.with_config(continual=None).monitor is None
    assert other.eps == Schedule(0.5, 0.01) and som.eps == SOMConfig().eps
    for option, value in (("lattice", (4, 3, 2)), ("input_dim", 3)):
        with pytest.raises(ValueError, match=f"{option} cannot change on a learned map"):
            som.with_config(**{option: value})


@pytest.mark.parametrize("name", SOMConfig.names())
def test_options_are_read_only(name):
    som = VisuomotorSOM(LOWER, UPPER, rng=0)
    assert getattr(som, name) == getattr(SOMConfig(), name)
    with pytest.raises(AttributeError, match=f"with_config\\({name}="):
        setattr(som, name, getattr(som, name))


def test_unknown_options_are_refused_naming_the_valid_ones():
    with pytest.raises(ValueError, match=r"unknown map option.*colour.*valid: lattice, input_dim"):
        VisuomotorSOM(LOWER, UPPER, colour="red")
    with pytest.raises(ValueError, match=r"unknown map option.*kernel"):
        VisuomotorSOM(LOWER, UPPER, rng=0).with_config(kernel="numpy")


def _everything_else() -> SOMConfig:
    """A configuration whose every field differs from the default."""
    return SOMConfig(
        lattice=(5, 4), input_dim=3, theta_target="fine-error", averaging="winner", refine=False,
        abar="average", t_max=77, eps=(0.7, 0.07), sigma=(1.5, 0.2), eps_out=(0.3, 0.03),
        sigma_out=(2.2, 0.3), explore=(0.0, 0.0), gamma=(0.9, 0.2), a_init=0.25, min_dv=0.5,
        sensing_noise=0.1,
        protocol="brause", continual=Continual(fast=0.05, trigger=2.0, readapt=50), recover=True,
    )  # fmt: skip


def test_every_field_survives_the_checkpoint_entries():
    config = _everything_else()
    default = SOMConfig()
    for f in fields(SOMConfig):
        assert getattr(config, f.name) != getattr(default, f.name), f.name
    entries = json.loads(json.dumps(config.to_dict()))  # as the file stores them
    assert SOMConfig.from_dict(entries) == config
    assert SOMConfig.from_dict(json.loads(json.dumps(default.to_dict()))) == default


def test_a_map_file_keeps_every_option(tmp_path):
    som = VisuomotorSOM(LOWER, UPPER, _everything_else(), rng=0, kernel="numpy")
    assert VisuomotorSOM.load(som.save(tmp_path / "m.npz")).config == som.config


def test_entries_written_before_an_option_existed_take_the_old_defaults():
    entries = SOMConfig(abar="average", protocol="brause").to_dict()
    for key in ("abar", "protocol"):
        del entries[key]
    del entries["schedules"]["gamma"]
    old = SOMConfig.from_dict(entries)
    assert (old.abar, old.protocol, old.gamma) == ("local-fit", "mrs", Schedule(1.0, 0.1))


@pytest.mark.parametrize(
    ("key", "value", "named"),
    [
        ("lattice", "12x7x4", "'lattice'"),
        ("lattice", [3, 0], "lattice"),
        ("input_dim", True, "'input_dim'"),
        ("input_dim", 0, "input_dim"),
        ("rule", "kohonen", "rule 'kohonen'; valid: mrs, brause"),
        ("averaging", 3, "'averaging'"),
        ("refine", "yes", "'refine'"),
        ("abar", "median", "abar 'median'; valid: average, local-fit"),
        ("t_max", 2.5, "'t_max'"),
        ("t_max", -10, "t_max"),
        ("a_init", -0.1, "a_init"),
        ("min_dv", -1, "min_dv"),
        ("min_dv", "0.1", "'min_dv'"),
        ("protocol", "ritter", "protocol 'ritter'; valid: mrs, brause"),
        ("schedules", {"eps": [1.0]}, "'schedules' holds 'eps'"),
        ("schedules", {"epsilon": [1.0, 0.1]}, "'schedules' holds 'epsilon'"),
        (
            "schedules",
            {**SOMConfig().to_dict()["schedules"], "eps_out": [0.5, 3.0]},
            "eps_out is a learning rate",
        ),
        ("schedules", {"gamma": [1.0, 0.1]}, "'schedules' lacks 'eps'"),
        ("continual", {"fast": 0.5, "speed": 2}, "'continual'"),
        ("continual", [0.02], "'continual'"),
    ],
)
def test_damaged_entries_are_refused_naming_the_entry(key, value, named):
    entries = SOMConfig().to_dict()
    entries[key] = value
    with pytest.raises(ValueError, match=named):
        SOMConfig.from_dict(entries)


def test_missing_entries_are_refused_naming_the_entry():
    entries = SOMConfig().to_dict()
    del entries["t_max"]
    with pytest.raises(ValueError, match="'t_max' is missing"):
        SOMConfig.from_dict(entries)


@pytest.mark.parametrize(
    ("options", "named"),
    [
        ({"protocol": "ritter"}, "protocol 'ritter'; valid: " + ", ".join(PROTOCOLS)),
        ({"abar": "median"}, "abar 'median'; valid: " + ", ".join(ABAR)),
        ({"refine": 1}, "refine"),
        ({"lattice": (3, -1)}, "lattice"),
        ({"input_dim": 2.5}, "input_dim"),
        ({"t_max": 0}, "t_max"),
        ({"min_dv": -0.1}, "min_dv"),
        ({"a_init": float("nan")}, "a_init"),
        ({"explore": "wide"}, "explore"),
        ({"sigma": (1.0, float("inf"))}, "sigma"),
        ({"continual": {"fast": 0.1}}, "continual"),
    ],
)
def test_bad_values_name_the_field(options, named):
    with pytest.raises(ValueError, match=named.replace("(", r"\(")):
        SOMConfig(**options)


def test_all_schedules_are_stored():
    assert set(SOMConfig().to_dict()["schedules"]) == set(SCHEDULES)


# ---------------------------------------------------------------------------- evaluate.py
@pytest.fixture(scope="module")
def mrs_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("mrs_run")
    train.main(["--trials", "300", "--lattice", "4x3x2", "--eval-every", "300", "--eval-trials",
                "5", "--out", str(out)])  # fmt: skip
    return out


def _evaluate(run: Path, out: Path, protocol: str) -> dict:
    result = subprocess.run(
        [sys.executable, str(SCRIPTS / "evaluate.py"), "--run", str(run), "--targets", "40",
         "--protocol", protocol, "--no-plots", "--out", str(out)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return json.loads((out / "evaluation.json").read_text())["controllers"][0]


def test_evaluate_protocol_brause_on_an_mrs_map_moves_as_brause(mrs_run, tmp_path):
    brause = _evaluate(mrs_run, tmp_path / "brause", "brause")
    mrs = _evaluate(mrs_run, tmp_path / "mrs", "mrs")
    assert brause["controller"] == "som brause" and mrs["controller"].startswith("som mrs")
    # Brause's fine move (3.7) does not use what was sensed: the second repeats the first.
    assert brause["mean_mm"][2] == brause["mean_mm"][1]
    assert brause["complete_fraction"] == 1.0
    # MRS's fine moves correct from what was sensed: the second improves on the first.
    assert mrs["mean_mm"][2] < mrs["mean_mm"][1]


# ------------------------------------------------------------------ the entries as files hold them
#: What ``SOMConfig().to_dict()`` wrote before the options were generated from the fields
#: (copied from that code's output): the same keys, values and order.
MAIN_DEFAULT_ENTRIES = {
    "lattice": [12, 7, 4], "input_dim": 4, "rule": "mrs", "averaging": "neighbourhood",
    "refine": True, "abar": "local-fit", "t_max": 10000,
    "schedules": {"eps": [1.0, 0.005], "sigma": [2.0, 0.1], "eps_out": [0.9, 0.1],
                  "sigma_out": [2.5, 0.01], "explore": [0.05, 0.005], "gamma": [1.0, 0.1]},
    "a_init": 0.1, "min_dv": 0.001, "protocol": "mrs",
}  # fmt: skip
#: ... and for a configuration with every optional entry present (the same code's output).
MAIN_OTHER_ENTRIES = {
    "lattice": [5, 4], "input_dim": 3, "rule": "brause", "averaging": "winner", "refine": False,
    "abar": "average", "t_max": 500,
    "schedules": {"eps": [0.5, 0.01], "sigma": [1.0, 1.0], "eps_out": [0.9, 0.1],
                  "sigma_out": [2.5, 0.01], "explore": [0.05, 0.005], "gamma": [1.0, 0.1]},
    "a_init": 0.0, "min_dv": 0.01, "protocol": "brause",
    "continual": {"fast": 0.02, "slow": 0.001, "trigger": 1.5, "rewind": 0.25, "readapt": 3000},
    "recover": True, "sensing_noise": 0.5,
}  # fmt: skip


def _other() -> SOMConfig:
    return SOMConfig(
        lattice=(5, 4), input_dim=3, theta_target="fine-error", averaging="winner",
        refine=False, abar="average", t_max=500, eps=(0.5, 0.01), sigma=1.0, a_init=0,
        min_dv=0.01, sensing_noise=0.5, protocol="brause", continual=Continual(), recover=True,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("config", "expected"),
    [(SOMConfig(), MAIN_DEFAULT_ENTRIES), (_other(), MAIN_OTHER_ENTRIES)],
    ids=["defaults", "every-entry"],
)
def test_the_entries_are_those_files_hold(config, expected):
    entries = config.to_dict()
    assert entries == expected
    assert list(entries) == list(expected)  # the order too
    assert list(entries["schedules"]) == list(expected["schedules"])
    assert SOMConfig.from_dict(json.loads(json.dumps(expected))) == config


def test_an_old_rule_entry_reads_as_the_new_theta_target():
    for old, new in (("mrs", "coarse-error"), ("brause", "fine-error")):
        assert SOMConfig.from_dict({**MAIN_DEFAULT_ENTRIES, "rule": old}).theta_target == new
        assert SOMConfig.of(rule=old).theta_target == new  # callers written before the rename
        assert SOMConfig(theta_target=new).rule == old


def test_the_old_option_name_is_refused_naming_the_new_one():
    with pytest.raises(
        ValueError,
        match=r"no option 'rule': it is 'theta_target' = "
        r"'coarse-error' \(was 'mrs'\), 'fine-error' \(was 'brause'\)",
    ):
        SOMConfig(rule="mrs")


def test_every_field_declares_its_help_and_run_flag():
    for config_cls in (SOMConfig, HierarchicalConfig):
        for f in fields(config_cls):
            assert isinstance(f.metadata["help"], str) and f.metadata["help"], f.name
            assert "\n" not in f.metadata["help"], f.name
            assert isinstance(f.metadata["run"], bool), f.name
            choices = f.metadata.get("choices")
            assert choices is None or (
                isinstance(choices, tuple) and getattr(config_cls(), f.name) in choices
            ), f.name


def test_the_run_options_are_the_ones_a_training_run_stores():
    assert [f.name for f in run_options(SOMConfig)] == [
        "lattice", "theta_target", "refine", "abar", "protocol", "sensing_noise",
    ]  # fmt: skip
    assert [f.name for f in run_options(HierarchicalConfig)] == [
        "position_lattice", "orientation_lattice", "refine",
    ]  # fmt: skip
    assert dict(fields(SOMConfig)[2].metadata)["choices"] == THETA_TARGETS


def test_the_entries_of_files_written_before_an_option_are_declared_on_it():
    late = {
        f.name: f.metadata["added_later"] for f in fields(SOMConfig) if "added_later" in f.metadata
    }
    assert late == {"abar": "local-fit", "gamma": Schedule(1.0, 0.1), "protocol": "mrs"}
    late = {
        f.name: f.metadata["added_later"]
        for f in fields(HierarchicalConfig) if "added_later" in f.metadata
    }  # fmt: skip
    assert late == {"backtrack": True, "trust_radius": 0.0}


def test_the_map_has_a_read_only_attribute_for_every_field_and_the_old_name():
    som = VisuomotorSOM(LOWER, UPPER, _other(), rng=0, kernel="numpy")
    for f in fields(SOMConfig):
        assert getattr(som, f.name) == getattr(som.config, f.name)
    assert som.rule == "brause"
    with pytest.raises(AttributeError, match=r"with_config\(theta_target="):
        som.rule = "mrs"
