"""A training run holds its map's config: the run options declared on the map's config
dataclasses are the run's settings, its stored entries, its sweep axes and its train.py flags,
and a run stored by earlier releases reads back to the same bytes."""

from __future__ import annotations

import json

import pytest
from test_cli_options import option_actions, program_parser

from envs.cli import train
from envs.harness.training import REACH_ONLY, RunConfig
from envs.sizes import format_lattice
from envs.studies.sweep_grid import expand
from learners.som.config import SOMConfig
from learners.som.hierarchical_config import HierarchicalConfig
from learners.som.options import run_key, run_options

from helpers import one_line_error, run_script

#: Checkpoint configurations as earlier releases wrote them (RunConfig held copies of the map's
#: fields then): a reach run with Brause's θ target and the sensing-noise step, a grasp run as
#: a sweep cell (explicit nested lattice) and as train.py wrote one (no nested lattice).
OLD_REACH = {
    "abar": "average", "control": "kinematic", "env": "PumaReach-v0", "eval_every": 500,
    "eval_trials": 100, "fine_moves": 2, "height": 240, "keep_arm": False, "lattice": [6, 5, 4],
    "protocol": "brause", "refine": False, "rule": "brause", "seed": 3, "sensing": "project",
    "sensing_noise": 0.1, "trials": 1500, "width": 320,
}  # fmt: skip
OLD_GRASP_CELL = {
    "abar": "local-fit", "control": "kinematic", "env": "PumaGrasp-v0", "eval_every": 1000,
    "eval_trials": 200, "fine_moves": 2, "height": 240, "keep_arm": False, "lattice": [4, 4, 3],
    "orientation_lattice": [3, 3, 2], "orientations": "ball:30", "protocol": "mrs",
    "refine": True, "rule": "mrs", "seed": 0, "sensing": "project", "training_pairs": 1,
    "trials": 50, "width": 320,
}  # fmt: skip


@pytest.mark.parametrize("stored", [OLD_REACH, OLD_GRASP_CELL], ids=["reach", "grasp"])
def test_a_run_stored_by_earlier_releases_reads_back_to_the_same_entries(stored):
    config = RunConfig.from_stored(stored)
    assert config.to_stored() == stored
    assert json.dumps(config.to_stored(), sort_keys=True) == json.dumps(stored, sort_keys=True)


def test_the_run_holds_its_maps_config_with_the_stored_options():
    reach = RunConfig.from_stored(OLD_REACH).map
    assert isinstance(reach, SOMConfig)
    assert (reach.lattice, reach.theta_target, reach.protocol, reach.refine) == (
        (6, 5, 4), "fine-error", "brause", False,
    )  # fmt: skip
    assert (reach.abar, reach.sensing_noise, reach.t_max) == ("average", 0.1, 1500)
    grasp = RunConfig.from_stored(OLD_GRASP_CELL).map
    assert isinstance(grasp, HierarchicalConfig)
    assert (grasp.position_lattice, grasp.orientation_lattice) == ((4, 4, 3), (3, 3, 2))
    assert (grasp.t_max, grasp.image_size) == (50, (320, 240))
    # an old train.py grasp run stored no nested lattice: the map's default
    old_cli = {k: v for k, v in OLD_GRASP_CELL.items() if k != "orientation_lattice"}
    assert RunConfig.from_stored(old_cli).map.orientation_lattice == (2, 2, 2)


def test_the_maps_t_max_and_image_size_follow_the_run():
    config = RunConfig(env="PumaGrasp-v0", trials=77, width=640, height=480)
    assert (config.map.t_max, config.map.image_size) == (77, (640, 480))
    assert RunConfig(map=SOMConfig(t_max=5), trials=9).map.t_max == 9


def test_a_map_option_the_run_does_not_store_is_refused():
    with pytest.raises(ValueError, match=r"run options .* not min_dv"):
        RunConfig(map=SOMConfig(min_dv=0.5))
    with pytest.raises(ValueError, match="HierarchicalConfig, not SOMConfig"):
        RunConfig(env="PumaGrasp-v0", map=SOMConfig())
    with pytest.raises(ValueError, match=r"reach map's option.*protocol"):
        RunConfig.of(env="PumaGrasp-v0", protocol="brause")
    with pytest.raises(ValueError, match="orientation_lattice is for the grasp envs"):
        RunConfig.of(orientation_lattice=(2, 2, 2))
    with pytest.raises(ValueError, match=r"unknown setting.*neurons"):
        RunConfig.of(neurons=8)


def test_every_run_option_of_either_map_is_a_train_flag_and_a_sweep_axis(monkeypatch):
    flags = set(option_actions(program_parser("train", monkeypatch)))
    for kind in (SOMConfig, HierarchicalConfig):
        for f in run_options(kind):
            key = run_key(f)
            assert (
                "--" + (key if f.name == "position_lattice" else f.name).replace("_", "-") in flags
            )
            env = "PumaGrasp-v0" if kind is HierarchicalConfig else "RiacsReach-v0"
            default = getattr(kind(), f.name)
            value = format_lattice(default) if isinstance(default, tuple) else default
            if key == "rule":
                value = "mrs"
            assert expand({"env": env, key: [value]})[0] == RunConfig.of(env=env)
    assert set(REACH_ONLY) == {"rule", "abar", "protocol", "sensing_noise"}


def test_rule_is_the_old_spelling_of_theta_target(monkeypatch):
    parser = program_parser("train", monkeypatch)
    monkeypatch.undo()
    old = parser.parse_args(["--rule", "brause"])
    new = parser.parse_args(["--theta-target", "fine-error"])
    assert train.map_settings(old, {"rule"}) == train.map_settings(new, {"theta_target"})
    assert train.map_settings(new, {"theta_target"})["rule"] == "brause"


def test_map_flags_that_do_not_fit_are_one_line_errors(tmp_path):
    both = run_script(
        "train", "--rule", "mrs", "--theta-target", "fine-error", "--out", str(tmp_path)
    )
    assert "old name of --theta-target" in one_line_error(both)
    grasp = run_script("train", "--env", "PumaGrasp-v0", "--theta-target", "fine-error",
                       "--out", str(tmp_path / "g"))  # fmt: skip
    assert "--theta-target: the reach map's" in one_line_error(grasp)
    assert not (tmp_path / "g").exists()


@pytest.mark.parametrize(
    ("setting", "value"),
    [("trials", 2**200), ("eval_every", 10**9), ("eval_trials", 10**7), ("fine_moves", 10**4),
     ("width", 10**6)],
)  # fmt: skip
def test_a_stored_count_beyond_what_fits_in_memory_and_time_is_refused(setting, value):
    stored = RunConfig().to_stored() | {setting: value}
    with pytest.raises(ValueError, match=rf"^{setting} is .*; it takes an integer <= "):
        RunConfig.from_stored(stored)
