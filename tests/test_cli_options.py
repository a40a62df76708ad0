"""The command-line programs' options: each program keeps the flags it had (literal lists taken
from the programs before the shared options), a shared flag is declared in one place, and
``add_config_options`` makes flags from a dataclass's marked fields."""

from __future__ import annotations

import argparse
import importlib
import re
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from envs.cli import common as cli
from envs.cli import options
from envs.cli.config_options import add_config_options, config_values

CLI = Path(__file__).resolve().parent.parent / "envs" / "cli"

#: Every program's flags as they were before the shared option groups (besides --help).
FLAGS = {
    "adapt": {"--abar", "--after", "--changes", "--control", "--envs", "--eval-trials", "--every",
              "--out", "--pre-every", "--pretrained", "--seed", "--sensing", "--train-trials",
              "--video-trials", "--warmup"},
    "bench_envs": {"--agents-only", "--json", "--peer-steps", "--rl-clock", "--rl-only",
                   "--rl-rounds", "--rl-steps", "--sb3-rounds", "--sb3-steps", "--seed",
                   "--sense-repeats", "--steps"},
    "bench_ik": {"--batch", "--repeats", "--robots", "--seed", "--single"},
    "bench_natenet": {"--net", "--nodes", "--out", "--queries", "--repeats", "--seed"},
    "bench_som": {"--batch", "--big", "--big-trials", "--block", "--lattice", "--out", "--rounds",
                  "--seed", "--trials"},
    "bench_workers": {"--control", "--env", "--fine-moves", "--lattice", "--out", "--round-sizes",
                      "--seed", "--seeds", "--sensing", "--targets", "--trials", "--workers"},
    "bench_trials": {"--block", "--envs", "--json", "--seed", "--settle-speeds", "--trials"},
    "compare_rl": {"--also-at", "--budget", "--checkpoints", "--control", "--env",
                   "--episode-steps", "--methods", "--out", "--report-only", "--seeds",
                   "--sensing", "--table-at", "--targets", "--variants"},
    "demo": {"--out", "--targets", "--trials"},
    "docs_media": {"--out", "--seed", "--trials"},
    "framing": {"--json", "--moves", "--pixel-moves", "--seed", "--sheet"},
    "evaluate": {"--abar", "--compare", "--control", "--controller", "--env", "--fine-moves",
                 "--image-size", "--no-backtrack", "--no-plots", "--no-refine", "--orientations",
                 "--out", "--protocol", "--recover", "--run", "--seed", "--sensing", "--targets",
                 "--trust-radius"},
    "grasp_learning": {"--fine-moves", "--out", "--seed", "--targets", "--trials-per-leaf"},
    "kinematic_accuracy": {"--levels", "--out", "--pose", "--robot", "--seed"},
    "reproduce_brause": {"--dx", "--edge", "--lattices", "--no-som", "--out", "--points",
                         "--scan-spacing", "--seed"},
    "riacs_dataset": {"--no-replace", "--out", "--seed", "--stepsize", "--test", "--train"},
    "sensing_accuracy": {"--image-size", "--json", "--poses", "--seed"},
    "sweep": {"--address", "--checkpoint-every", "--grid", "--num-cpus", "--out", "--retries",
              "--spec"},
    "train": {"--abar", "--address", "--checkpoint-every", "--control", "--env", "--eval-every",
              "--eval-trials", "--force", "--image-size", "--keep-arm", "--lattice",
              "--orientation-lattice", "--orientations", "--out", "--protocol", "--refine",
              "--resume", "--rule", "--seed", "--sensing", "--sensing-noise", "--theta-target",
              "--training-pairs", "--trials", "--workers"},
    "train_natenet": {"--T-a", "--T0", "--e-f", "--eta", "--exploration", "--gain",
                      "--input-dim", "--lam", "--max-nodes", "--no-video", "--out", "--seed",
                      "--sensing", "--tau", "--test-paths", "--train-paths"},
    "video": {"--compare", "--control", "--controller", "--env", "--fine-moves", "--fps", "--out",
              "--seed", "--sensing", "--speed", "--trials"},
}  # fmt: skip

#: Every registered reach and grasp env.
ENV_CHOICES = {
    "RiacsReach-v0", "PumaReach-v0", "Ur5eReach-v0", "PandaReach-v0",
    "PumaGrasp-v0", "Ur5eGrasp-v0", "PandaGrasp-v0",
}  # fmt: skip
#: (program, flag): (default, choices) as they were, for the shared options that vary most.
SHARED = {
    ("train", "--sensing"): ("project", {"render", "project", "foveated"}),
    ("train", "--control"): ("kinematic", {"servo", "kinematic"}),
    ("train", "--env"): ("RiacsReach-v0", ENV_CHOICES),
    ("train", "--out"): (Path("runs/train"), None),
    ("train", "--address"): (None, None),
    ("sweep", "--address"): (None, None),
    ("evaluate", "--sensing"): (None, {"render", "project", "foveated"}),
    ("evaluate", "--env"): (None, ENV_CHOICES),
    ("evaluate", "--out"): (None, None),
    ("video", "--sensing"): ("foveated", {"render", "project", "foveated"}),
    ("video", "--control"): ("servo", {"servo", "kinematic"}),
    ("video", "--seed"): (1, None),
    ("adapt", "--sensing"): ("project", {"render", "project"}),
    ("compare_rl", "--sensing"): ("project", {"render", "project"}),
    ("compare_rl", "--env"): (["RiacsReach-v0", "PumaReach-v0"],
                              ENV_CHOICES),
    ("train_natenet", "--sensing"): ("project", {"render", "project"}),
    ("docs_media", "--seed"): (1, None),
    ("bench_som", "--lattice"): ((12, 7, 4), None),
}  # fmt: skip


class _Parsed(Exception):
    """Raised instead of parsing: carries the parser a program built."""


def program_parser(name: str, monkeypatch) -> argparse.ArgumentParser:
    """The parser the program ``envs.cli.<name>`` builds, caught where it would parse."""

    def caught(self, *args, **kwargs):
        raise _Parsed(self)

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", caught)
    program = importlib.import_module(f"envs.cli.{name}")
    entry = getattr(program, "parse_args", None) or program.main
    with pytest.raises(_Parsed) as caught_parser:
        entry([])
    return caught_parser.value.args[0]


def option_actions(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {
        a.option_strings[0]: a
        for a in parser._actions
        if a.option_strings and "--help" not in a.option_strings
    }


@pytest.mark.parametrize("name", sorted(FLAGS))
def test_every_program_keeps_its_flags(name, monkeypatch):
    assert set(option_actions(program_parser(name, monkeypatch))) == FLAGS[name]


@pytest.mark.parametrize(("name", "flag"), sorted(SHARED))
def test_shared_options_keep_each_programs_default_and_choices(name, flag, monkeypatch):
    action = option_actions(program_parser(name, monkeypatch))[flag]
    default, choices = SHARED[name, flag]
    value = action.default
    if isinstance(value, str) and action.type is not None:
        value = action.type(value)  # argparse converts a string default through the type
    assert value == default
    assert (None if action.choices is None else set(action.choices)) == choices


@pytest.mark.parametrize("name", ["train", "evaluate", "video", "reproduce_brause", "bench_envs"])
def test_help_works(name, capsys):
    program = importlib.import_module(f"envs.cli.{name}")
    entry = getattr(program, "parse_args", None) or program.main
    with pytest.raises(SystemExit) as done:
        entry(["--help"])
    assert done.value.code == 0
    assert "--seed" in capsys.readouterr().out


@pytest.mark.parametrize("name", ["train", "adapt", "compare_rl"])
def test_help_says_a_run_and_an_env_default_differently(name, monkeypatch):
    actions = option_actions(program_parser(name, monkeypatch))
    assert "default: project, a training run's" in actions["--sensing"].help
    assert "gym.make defaults to render" in actions["--sensing"].help
    assert "default: kinematic, a training run's" in actions["--control"].help
    assert "gym.make defaults to servo" in actions["--control"].help


def test_the_notes_defaults_are_the_envs_and_the_runs():
    import gymnasium as gym

    import envs  # noqa: F401
    from envs.harness.training import RunConfig

    env = gym.make("RiacsReach-v0").unwrapped
    try:
        assert f"gym.make defaults to {env.sensing}" in options.run_setting_note("sensing")
        assert f"gym.make defaults to {env.control}" in options.run_setting_note("control")
    finally:
        env.close()
    assert options.run_setting_note("sensing").startswith(f"default: {RunConfig().sensing},")


#: The flags that several programs take.
SHARED_FLAGS = ("--seed", "--out", "--sensing", "--control", "--env", "--image-size",
                "--fine-moves", "--targets", "--json", "--controller", "--orientations",
                "--checkpoint-every", "--trials", "--eval-trials", "--lattice", "--protocol",
                "--abar", "--address")  # fmt: skip


@pytest.mark.parametrize("flag", SHARED_FLAGS)
def test_a_shared_flag_is_declared_once_in_the_cli(flag):
    quoted = rf"\(\s*[\"']{re.escape(flag)}[\"']"
    declared = {
        path.name: len(re.findall(rf"(add_argument|Option){quoted}", path.read_text()))
        for path in CLI.glob("*.py")
    }
    assert {name: n for name, n in declared.items() if n} == {"options.py": 1}


# ---- add_config_options, on a dataclass of its own


@dataclass(frozen=True)
class Toy:
    lattice: tuple[int, ...] = field(default=(3, 4), metadata={"run": True, "help": "shape"})
    t_max: int = field(default=50, metadata={"run": True, "help": "trials"})
    rate: float = field(default=0.5, metadata={"run": True})
    refine: bool = field(default=True, metadata={"run": True, "help": "refine"})
    rule: str = field(default="a", metadata={"run": True, "choices": ("a", "b")})
    label: str = field(default="x", metadata={"run": True})
    limit: int | None = field(default=None, metadata={"run": True})
    hidden: int = 7  # no "run": not an option
    names: tuple[str, ...] = field(default=(), metadata={"added_later": True})


def toy_parser() -> tuple[argparse.ArgumentParser, list[str]]:
    p = cli.parser("toy")
    return p, add_config_options(p, Toy)


def test_config_options_are_the_marked_fields_with_their_defaults():
    p, names = toy_parser()
    assert names == ["lattice", "t_max", "rate", "refine", "rule", "label", "limit"]
    flags = set(option_actions(p))
    assert flags == {"--lattice", "--t-max", "--rate", "--refine", "--rule", "--label", "--limit"}
    assert Toy(**config_values(p.parse_args([]), Toy)) == Toy()


def test_config_options_parse_each_type():
    p, _ = toy_parser()
    argv = ["--lattice", "5x6x7", "--t-max", "9", "--rate", "1e-3", "--no-refine", "--rule", "b",
            "--label", "y", "--limit", "3"]  # fmt: skip
    values = config_values(p.parse_args(argv), Toy)
    assert Toy(**values) == Toy((5, 6, 7), 9, 1e-3, False, "b", "y", 3)
    assert p.parse_args(["--refine"]).refine is True


def test_config_options_have_the_fields_help_and_choices():
    p, _ = toy_parser()
    actions = option_actions(p)
    assert actions["--lattice"].help.startswith("shape") and "3x4" in actions["--lattice"].help
    assert actions["--rule"].choices == ("a", "b")
    assert "--no-refine" in actions["--refine"].option_strings


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--rule", "c"], "invalid choice: 'c'"),
        (["--t-max", "1.5"], "wants an integer, got '1.5'"),
        (["--rate", "nan"], "wants a finite number, got 'nan'"),
        (["--lattice", "3xx"], "--lattice"),
    ],
)
def test_config_options_refuse_bad_values_in_one_line(argv, message, capsys):
    p, _ = toy_parser()
    with pytest.raises(SystemExit) as done:
        p.parse_args(argv)
    assert done.value.code == cli.USAGE_ERROR
    error = capsys.readouterr().err.strip()
    assert message in error and "\n" not in error


def test_config_options_leave_out_and_redefault_fields_by_name():
    p = cli.parser("toy")
    names = add_config_options(p, Toy, skip=("label", "limit"), defaults={"lattice": None})
    assert names == ["lattice", "t_max", "rate", "refine", "rule"]
    assert "--label" not in option_actions(p)
    assert p.parse_args([]).lattice is None
    assert set(config_values(p.parse_args([]), Toy, skip=("label", "limit"))) == set(names)
    with pytest.raises(ValueError, match=r"\['hidden'\] are no run fields of Toy: lattice, "):
        add_config_options(cli.parser("toy"), Toy, skip=("hidden",))


def test_a_marked_field_of_an_unknown_type_is_a_clear_error():
    @dataclass
    class Bad:
        pairs: dict = field(default_factory=dict, metadata={"run": True})

    with pytest.raises(TypeError, match="pairs: a command-line option cannot be made from"):
        add_config_options(argparse.ArgumentParser(), Bad)
