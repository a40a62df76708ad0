"""One convention for sizes: ``width=``/``height=`` in Python, WIDTHxHEIGHT and 12x7x4 in text,
the cameras' aspect ratio enforced in the env, on the command line and in sweep grids, and
checkpoints that keep their image size (also those that stored it as [height, width])."""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (chooses the GL back-end, registers the envs)
from envs import sizes
from envs.cli import train
from envs.harness.checkpoint import CHECKPOINT_FILE, check_map_fits, read_unit, write_unit
from envs.harness.training import RunConfig, Trainer
from envs.robots import ROBOTS
from envs.studies.sweep_grid import cell_name, expand
from learners.persistence import CheckpointError
from learners.som.controller import VisuomotorSOM

TINY = {"trials": 1, "lattice": (2, 2, 2), "eval_every": 1, "eval_trials": 2}


def test_gym_make_takes_width_and_height_as_gymnasium_envs_do():
    env = gym.make("RiacsReach-v0", width=640, height=480, sensing="render", control="kinematic")
    env.reset(seed=0)
    base = env.unwrapped
    (image, depth), _ = base.stereo.render_views(base.data, (0, 2))
    assert image.shape == (480, 640, 3) and depth.shape == (480, 640)  # 480 rows, 640 columns
    high = env.observation_space["achieved_goal"].high
    np.testing.assert_array_equal(high, [639, 479, 639, 479])
    env.close()


@pytest.mark.parametrize("env_id", ["RiacsReach-v0", "PumaReach-v0"])
def test_a_portrait_size_is_refused_naming_both(env_id):
    with pytest.raises(sizes.ImageSizeError) as error:
        gym.make(env_id, width=480, height=640, sensing="project", control="kinematic")
    message = str(error.value)
    assert "480x640 (width x height)" in message and "4:3" in message
    assert "\n" not in message


def test_the_riacs_cameras_are_made_for_the_declared_aspect():
    env = gym.make("RiacsReach-v0", sensing="project", control="kinematic").unwrapped
    for name in ("cam_left", "cam_right"):
        across, down = env.model.cam_sensorsize[env.model.camera(name).id]
        assert across / down == pytest.approx(np.divide(*ROBOTS["riacs"].image_aspect), rel=1e-6)
    env.close()


def test_text_sizes_and_lattices_go_both_ways():
    assert sizes.parse_size("640x480") == (640, 480)
    assert sizes.format_size(640, 480) == "640x480"
    assert sizes.parse_lattice("12x7x4") == (12, 7, 4)
    assert sizes.format_lattice((12, 7, 4)) == "12x7x4"
    with pytest.raises(ValueError, match="write 12x7x4"):
        sizes.parse_lattice("12,7,4")
    with pytest.raises(ValueError, match="WIDTHxHEIGHT"):
        sizes.parse_size("640,480")


def test_cli_refuses_a_portrait_image_size_in_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        train.main(["--image-size", "480x640", "--out", str(tmp_path / "run")])
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "480x640" in err[0] and "4:3" in err[0]
    assert not (tmp_path / "run").exists()


def test_cli_lattice_is_written_12x7x4(tmp_path, capsys):
    assert train.cli.lattice("12x7x4") == (12, 7, 4)
    with pytest.raises(SystemExit) as exit_:
        train.main(["--lattice", "12,7,4", "--out", str(tmp_path / "run")])
    assert exit_.value.code == 2 and "write 12x7x4" in capsys.readouterr().err


def test_resume_conflicts_print_sizes_and_lattices_the_one_way():
    stored = RunConfig.of(lattice=(12, 7, 4))
    args = argparse.Namespace(lattice=(4, 3, 2), image_size=(640, 480))
    assert train.resume_conflicts(stored, args, {"lattice", "image_size"}) == [
        "--lattice 4x3x2 (the run has 12x7x4)",
        "--image-size 640x480 (the run has 320x240)",
    ]


def test_sweep_image_sizes_are_width_by_height_and_checked():
    (config,) = expand({"image_size": "640x480", "lattice": "12x7x4"})
    assert (config.width, config.height) == (640, 480)
    assert "12x7x4" in cell_name(config)
    with pytest.raises(ValueError, match="480x640"):
        expand({"image_size": "480x640"})


def test_checkpoints_keep_their_image_size_old_and_new(tmp_path):
    out = tmp_path / "run"
    trainer = Trainer(RunConfig.of(width=160, height=120, **TINY), out)
    trainer.close()
    path = Path(out) / CHECKPOINT_FILE
    assert (Trainer.stored_config(out).width, Trainer.stored_config(out).height) == (160, 120)
    som = VisuomotorSOM.load(path)
    other = gym.make("RiacsReach-v0", sensing="project", control="kinematic")  # 320x240
    with pytest.raises(CheckpointError, match="width=160, height=120"):
        check_map_fits(path, som, other)
    # A checkpoint written before width/height: its config and identity hold image_size =
    # [height, width].
    run, sim_state = read_unit(path)
    config, recorded = dict(run["config"]), dict(run["identity"])
    config["image_size"] = [config.pop("height"), config.pop("width")]
    recorded["image_size"] = [recorded.pop("height"), recorded.pop("width")]
    write_unit(path, som, {**run, "config": config, "identity": recorded}, sim_state)
    with pytest.raises(CheckpointError, match="width=160, height=120"):
        check_map_fits(path, som, other)
    old = Trainer.stored_config(out)
    assert (old.width, old.height) == (160, 120)
    resumed = Trainer.resume(out)
    assert (resumed.env.unwrapped.image_width, resumed.env.unwrapped.image_height) == (160, 120)
    resumed.close()
    other.close()
