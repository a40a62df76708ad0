"""The options several programs share, each declared once: its flag, type, choices and help.

A program adds one with ``SEED.add(parser)``, giving its own default where it has one
(``OUT.add(parser, default=Path("runs/train"))``) and, where the option means something narrower
there, a ``note`` that the shared help is followed by. Choices are read from where they are
defined: the env ids from ``envs.reach`` and ``envs.grasp``, sensing and control modes from the
envs, the map's choices from ``learners.som.config``.

The envs and the training runs default to different settings, both on purpose: an env made with
``gym.make`` is the realistic one (rendered sensing, servo moves), a training run
(``RunConfig``) the idealised one (exact projection, kinematic moves) that the headline results
use. :func:`run_setting_note` says so in the help of the programs that follow the run's
defaults.
"""

from __future__ import annotations

import argparse
import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

from envs.cli import common as cli
from envs.cli.controllers import SPECS, controller_spec
from envs.grasp import GRASP_ENV_IDS
from envs.harness.training import RunConfig
from envs.reach import CONTROL_MODES, REACH_ENV_IDS, SENSING_MODES, ReachEnv
from learners.som.config import ABAR, PROTOCOLS

#: Every env id the reach and pose programs take.
ENV_IDS = REACH_ENV_IDS + GRASP_ENV_IDS
#: Sensing that draws or projects whole images, without the foveated windows (the programs
#: whose studies were measured so: adaptation, the map against deep RL).
WHOLE_IMAGE_SENSING = tuple(mode for mode in SENSING_MODES if mode != "foveated")


@dataclass(frozen=True)
class Option:
    """One command-line option: its flag and the keyword arguments of ``add_argument``."""

    flag: str
    settings: Mapping[str, Any] = field(default_factory=dict)

    def add(
        self, parser: argparse.ArgumentParser, *, note: str | None = None, **overrides: Any
    ) -> argparse.Action:
        """Add the option to ``parser``; ``overrides`` replace its settings (a program's own
        default or choices), ``note`` follows the shared help after a semicolon."""
        settings = {**self.settings, **overrides}
        if note is not None:
            settings["help"] = f"{settings['help']}; {note}" if settings.get("help") else note
        return parser.add_argument(self.flag, **settings)

    def varied(self, **settings: Any) -> Option:
        """The same flag with some settings replaced: a shared variant (one help for the
        programs that give the flag the same meaning)."""
        return replace(self, settings={**self.settings, **settings})


@dataclass(frozen=True)
class ModeOption(Option):
    """An option that chooses a mode: its help describes the modes a program offers."""

    what: str = ""
    modes: Mapping[str, str] = field(default_factory=dict)

    def add(
        self, parser: argparse.ArgumentParser, *, note: str | None = None, **overrides: Any
    ) -> argparse.Action:
        choices = overrides.get("choices", self.settings["choices"])
        listed = ", ".join(f"{mode} ({self.modes[mode]})" for mode in choices)
        overrides.setdefault("help", f"{self.what}: {listed}")
        return super().add(parser, note=note, **overrides)


def run_setting_note(name: str) -> str:
    """For the help of ``--sensing`` or ``--control`` (``name``) in a program that takes a
    training run's default: that default, and that of an env made with ``gym.make``, read from
    ``RunConfig`` and ``ReachEnv``."""
    env_default = inspect.signature(ReachEnv.__init__).parameters[name].default
    return (
        f"default: {getattr(RunConfig, name)}, a training run's (RunConfig: the idealised "
        f"setting); an env made with gym.make defaults to {env_default} (ReachEnv: the "
        "realistic one)"
    )


ENV = Option("--env", {"choices": ENV_IDS, "help": "the env id"})
SENSING = ModeOption(
    "--sensing",
    {"choices": SENSING_MODES},
    "how the cameras sense",
    {
        "render": "detection in whole rendered images",
        "project": "exact pinhole projection",
        "foveated": "rendered windows around the expected pixels",
    },
)
CONTROL = ModeOption(
    "--control",
    {"choices": CONTROL_MODES},
    "how a command moves the arm",
    {"servo": "the position actuators, simulated", "kinematic": "the joints set at once"},
)
SEED = Option("--seed", {"type": cli.seed, "default": 0, "help": "random seed"})
#: ``--seed`` of a program that evaluates: it names an evaluation set of the evaluation stream
#: (``envs.harness.streams``), not a training seed.
EVALUATION_SET = SEED.varied(
    help="the evaluation set: held-out targets of the evaluation stream, which no training run "
    "draws for any seed (default: %(default)s)"
)
#: A program that writes one file (a video, a figure) adds it with ``type=cli.out_file``.
OUT = Option("--out", {"type": cli.out_folder, "help": "output folder"})
JSON = Option(
    "--json", {"type": cli.out_file, "default": None, "help": "also write the results here"}
)
IMAGE_SIZE = Option(
    "--image-size", {"type": cli.image_size, "help": "sensing images WIDTHxHEIGHT, e.g. 640x480"}
)
TRIALS = Option("--trials", {"type": cli.positive_int, "help": "trials"})
#: Held-out targets: their errors are kept in memory (``cli.MAX_TARGETS``).
TARGET_COUNT = cli.count(most=cli.MAX_TARGETS, why="each target's errors are kept in memory")
TARGETS = Option("--targets", {"type": TARGET_COUNT, "default": 1000, "help": "targets"})
FINE_MOVES = Option(
    "--fine-moves",
    {
        "type": cli.count(0, cli.MAX_FINE_MOVES, "each is a move of every trial"),
        "default": 2,
        "help": "fine moves after the coarse move",
    },
)
EVAL_TRIALS = Option(
    "--eval-trials", {"type": TARGET_COUNT, "help": "targets of each held-out evaluation"}
)
CHECKPOINT_EVERY = Option(
    "--checkpoint-every", {"type": cli.positive_int, "default": 1000, "help": "trials"}
)
LATTICE = Option("--lattice", {"type": cli.lattice, "help": "lattice shape"})
ORIENTATIONS = Option(
    "--orientations",
    {
        "type": cli.orientation_range,
        "help": "PumaGrasp-v0: the objects' orientation range, 'yaw:DEG,tilt:DEG' or 'ball:DEG'",
    },
)
PROTOCOL = Option("--protocol", {"choices": PROTOCOLS, "help": "how the map moves and learns"})
ABAR_OPTION = Option("--abar", {"choices": ABAR, "help": "Ā of the map's fine moves"})
ADDRESS = Option(
    "--address",
    {
        "type": cli.ray_address,
        "default": None,
        "help": "a Ray cluster (the extra sweep): auto (the one this machine joined with `ray "
        "start`), HOST:PORT (its head) or local (a new Ray instance on this machine)",
    },
)
CONTROLLER = Option("--controller", {"type": controller_spec, "help": SPECS})
