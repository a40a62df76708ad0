"""Training a learner on a reach env, trial by trial, with held-out evaluations and checkpoints
from which a run continues exactly as if it had never stopped: after Ctrl-C, SIGTERM, SIGKILL or
a power cut, ``Trainer.resume`` gives the arrays, generator states and metrics of an unbroken run.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from envs.grasp import GRASP_ENV_IDS
from envs.harness.checkpoint import (
    CHECKPOINT_FILE,
    OLD_CHECKPOINT_FILE,
    Map,
    check_identity,
    check_map_fits,
    checkpoint_path,
    get_sim_state,
    identity,
    load_map,
    read_unit,
    set_sim_state,
    unit_identity,
    write_unit,
)
from envs.harness.evaluation import Ticking, evaluate, evaluation_of
from envs.harness.ray_cluster import AddressError
from envs.harness.ray_workers import ray_pools
from envs.harness.run_folder import METRICS_FILE, RunFolder, check_metrics, truncate_metrics
from envs.harness.run_state import CHECKPOINT_EVERY, RunState
from envs.harness.stopping import SignalStop, StopRequested
from envs.harness.streams import seed_env
from envs.harness.trials import Trial, learn_from, run_trial
from envs.harness.workers import ROUND_TRIALS, Collected, RoundPool, WorkerPool, round_end
from envs.limits import MAX_COUNT, MAX_FINE_MOVES, MAX_TARGETS, MAX_WORKERS
from envs.reach import CONTROL_MODES, IMAGE_HEIGHT, IMAGE_WIDTH, REACH_ENV_IDS, SENSING_MODES
from envs.robots import ROBOTS, robot_of_env
from envs.sizes import check_image_size
from learners.persistence import CheckpointError, quoted
from learners.som.config import SOMConfig
from learners.som.controller import VisuomotorSOM
from learners.som.hierarchical import HierarchicalSOM
from learners.som.hierarchical_config import MAX_IMAGE_SIDE, HierarchicalConfig
from learners.som.options import (
    from_run_settings,
    run_defaults,
    run_entries,
    run_key,
    run_options,
    run_spelling,
)
from models.grasp_task import GraspTask
from models.puma560.grasp import NARROW

#: Run settings that ``--resume`` may change: ``trials`` (to go on past the old end; the map's
#: schedules then stay at their final values). Everything else defines the run.
RESUMABLE = ("trials",)
#: Targets the cameras see before training, whose pixel box spreads the map's w ...
INIT_TARGETS = 200
#: ... drawn with seed + this (neither a training nor a held-out seed).
INIT_SEED_OFFSET = 30_000
#: Weight of the newest trial in the running errors shown on the progress bar.
RUNNING_WEIGHT = 0.02
#: A run's map options: the reach map's on a reach env, the hierarchical map's on a grasp env.
MapConfig = SOMConfig | HierarchicalConfig
#: The map options a run spells the same on both maps' configs are one sweep axis and one entry;
#: these of the reach map (``SOMConfig``) the grasp envs' hierarchical map does not have.
REACH_ONLY = tuple(k for k in run_defaults(SOMConfig) if k not in run_defaults(HierarchicalConfig))
#: The map options a run takes, by the names and spellings it gives them, with their defaults:
#: both maps' run options (``learners.som.options.run_defaults``; ``lattice`` the reach map's).
SETTINGS = run_defaults(HierarchicalConfig) | run_defaults(SOMConfig)
#: A grasp run has always held the reach map's own options at their defaults (they were fields
#: of the run): its checkpoint keeps them, so that its file and its sweep cell's name keep their
#: bytes.
GRASP_RUN_ENTRIES = {k: SETTINGS[k] for k in REACH_ONLY}
#: Settings added after runs and sweep cells were named: left out of a stored or hashed
#: configuration while they hold these values, so those names and files do not change (the map
#: options that say so, ``omit_default``, and two fields).
ADDED_LATER = {
    run_key(f): run_spelling(f, f.default)
    for kind in (SOMConfig, HierarchicalConfig)
    for f in run_options(kind)
    if f.metadata.get("omit_default")
} | {"orientations": None, "training_pairs": None, "workers": 1}
#: The objects' orientations of a grasp run stored before runs recorded them (the 30° ball) ...
FIRST_ORIENTATIONS = NARROW.spec()
#: ... and its training pairs (one: the coarse and one fine move, learned once).
FIRST_TRAINING_PAIRS = 1
#: A grasp run's training trial: a coarse and this many exploratory fine moves, each pair of
#: consecutive moves learned: 4 of 1-4 on validation objects (envs/studies/pose_tail.py, both
#: orientation ranges, seeds 0-2: the means and the share over 1 mm or 1° fell most at the
#: same trials; docs/decisions.md). The grasp study's table keeps 1, its published figure's.
TRAINING_PAIRS = 4


def check_env_image_size(env_id: str, width: int, height: int) -> tuple[int, int]:
    """:func:`envs.sizes.check_image_size` against the cameras of the registered reach or grasp env
    ``env_id`` (ImageSizeError unless (width, height) px suits them)."""
    return check_image_size(width, height, ROBOTS[robot_of_env(env_id)].image_aspect)


def grasp_task(env_id: str) -> GraspTask:
    """The pose task of the robot of the grasp env ``env_id``."""
    task = ROBOTS[robot_of_env(env_id)].kinematics.grasp
    if task is None:
        raise ValueError(f"{env_id} is not a grasp env; the grasp envs: {GRASP_ENV_IDS}")
    return task


@dataclass(frozen=True)
class RunConfig:
    """Everything that defines a training run (stored in the checkpoint).

    On a reach env the run trains a :class:`~learners.som.controller.VisuomotorSOM` with the
    options ``map`` (a :class:`~learners.som.config.SOMConfig`); on a grasp env
    (``PumaGrasp-v0``) a :class:`~learners.som.hierarchical.HierarchicalSOM` with the options
    ``map`` (a :class:`~learners.som.hierarchical_config.HierarchicalConfig`). ``map`` None
    takes that config's defaults. A run sets only the map's run options (metadata ``"run"``:
    the lattices, ``theta_target``, ``refine``, ...): they are what its checkpoint stores. The
    map's ``t_max`` is always the run's ``trials``, the hierarchical map's image size the run's.

    :meth:`of` builds one from flat settings as the command line, a sweep grid and a checkpoint
    spell them (``lattice=(8, 8, 8)``, ``rule="brause"``).
    """

    env: str = "RiacsReach-v0"
    sensing: str = "project"
    control: str = "kinematic"
    seed: int = 0
    trials: int = 10_000
    keep_arm: bool = False
    eval_every: int = 1000
    eval_trials: int = 200
    fine_moves: int = 2
    width: int = IMAGE_WIDTH  # sensing images, px
    height: int = IMAGE_HEIGHT  # px
    #: grasp envs only: the objects' orientation range (``OrientationRange.parse``; None: the
    #: env's default, stored by its spelling)
    orientations: str | None = None
    #: grasp envs only: fine moves of a training trial, each learned after the one before it
    #: (``learn_from(..., pairs)``; None: TRAINING_PAIRS)
    training_pairs: int | None = None
    #: trials collected by this many worker processes in rounds (``envs.harness.workers``);
    #: 1: one process, trial after trial. (Where they run, local processes or Ray actors, is the
    #: Trainer's ``address``: it does not change the map, and is not stored.)
    workers: int = 1
    #: the map's options (None: its config's defaults; the constructor sets the checked config)
    map: MapConfig = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        """Checks every field, so that a configuration read back from a checkpoint or a sweep
        grid passes the same guards as one given on the command line (ValueError naming it)."""
        envs = REACH_ENV_IDS + GRASP_ENV_IDS
        choices = {"env": envs, "sensing": SENSING_MODES, "control": CONTROL_MODES}
        for name, valid in choices.items():
            if getattr(self, name) not in valid:
                raise ValueError(f"{name} is {getattr(self, name)!r}; valid: {', '.join(valid)}")
        ranges = {"seed": (0, None), "trials": (1, MAX_COUNT), "eval_every": (1, MAX_COUNT),
                  "eval_trials": (1, MAX_TARGETS), "fine_moves": (0, MAX_FINE_MOVES),
                  "width": (1, MAX_IMAGE_SIDE), "height": (1, MAX_IMAGE_SIDE),
                  "workers": (1, MAX_WORKERS)}  # fmt: skip
        for name, (low, high) in ranges.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"{name} is {quoted(repr(value))}; it takes an integer >= {low}")
            if high is not None and value > high:
                raise ValueError(
                    f"{name} is {quoted(repr(value))}; it takes an integer <= {high:,}"
                )
        if not isinstance(self.keep_arm, bool):
            raise ValueError(f"keep_arm is {self.keep_arm!r}, not true or false")
        if self.keep_arm and self.workers > 1:
            raise ValueError(
                f"keep_arm starts a trial where the last ended, which {self.workers} workers "
                "running trials side by side cannot; leave out keep_arm or take 1 worker"
            )
        if self.grasp and self.workers > 1:
            raise ValueError(
                f"workers > 1 trains the reach maps only: {self.env}'s hierarchical map cannot "
                "yet learn from trials an earlier copy of it made; take 1 worker"
            )
        if self.grasp:
            chosen = grasp_task(self.env).orientations(self.orientations)  # ValueError if none
            object.__setattr__(self, "orientations", None if chosen is None else chosen.spec())
            pairs = TRAINING_PAIRS if self.training_pairs is None else self.training_pairs
            if isinstance(pairs, bool) or not isinstance(pairs, int) or not 1 <= pairs <= 8:
                raise ValueError(f"training_pairs is {pairs!r}; it takes an integer in 1..8")
            object.__setattr__(self, "training_pairs", pairs)
        else:
            for name in ("orientations", "training_pairs"):
                if getattr(self, name) is not None:
                    raise ValueError(
                        f"{name} is for the grasp envs ({', '.join(GRASP_ENV_IDS)}), not "
                        f"{self.env}; leave it out"
                    )
        object.__setattr__(self, "map", self._checked_map())

    def _checked_map(self) -> MapConfig:
        """``map`` (or its config's defaults) checked against the env, its ``t_max`` (and
        image size) the run's."""
        kind: type[SOMConfig] | type[HierarchicalConfig]
        kind = HierarchicalConfig if self.grasp else SOMConfig
        given = kind() if self.map is None else self.map
        if not isinstance(given, kind):
            raise ValueError(
                f"{self.env} trains a map of {kind.__name__}, not {type(given).__name__}"
            )
        synced: dict[str, Any] = {"t_max": self.trials}
        if self.grasp:
            synced["image_size"] = (self.width, self.height)
        run = {f.name for f in run_options(kind)} | set(synced)
        changed = [f.name for f in fields(given) if f.name not in run and getattr(given, f.name)
                   != getattr(kind(), f.name)]  # fmt: skip
        if changed:
            raise ValueError(
                f"a run stores only its map's run options "
                f"({', '.join(f.name for f in run_options(kind))}), not {', '.join(changed)}"
            )
        return kind.of(given, **synced)

    @property
    def grasp(self) -> bool:
        """The run is on a grasp env (the hierarchical map)."""
        return self.env in GRASP_ENV_IDS

    @property
    def lattice(self) -> tuple[int, ...]:
        """The map's lattice (on a grasp env its position lattice)."""
        config = self.map
        return config.position_lattice if isinstance(config, HierarchicalConfig) else config.lattice

    @classmethod
    def of(cls, **settings: Any) -> RunConfig:
        """The run of flat ``settings``: RunConfig fields and the map's run options by the
        names and spellings a run gives them (``SETTINGS``): the reach map's on a reach env,
        the hierarchical map's on a grasp env. ValueError naming a setting that is unknown or
        does not fit the env (a reach map's option on a grasp env other than at its default)."""
        own = {f.name for f in fields(cls)} - {"map"}
        run = {k: v for k, v in settings.items() if k in own}
        env = run.get("env", cls.env)
        kind = HierarchicalConfig if env in GRASP_ENV_IDS else SOMConfig
        options = {k: list(v) if isinstance(v, tuple) else v
                   for k, v in settings.items() if k not in own and v is not None}  # fmt: skip
        unknown = sorted(set(options) - set(SETTINGS))
        if unknown:
            valid = ", ".join(sorted(own | set(SETTINGS)))
            raise ValueError(f"unknown setting(s) {', '.join(unknown)}; valid: {valid}")
        mine = run_defaults(kind)
        # a grasp run's file holds the reach map's defaults (GRASP_RUN_ENTRIES)
        foreign = [k for k, v in options.items()
                   if k not in mine and (kind is SOMConfig or v != SETTINGS[k])]  # fmt: skip
        if foreign and kind is HierarchicalConfig:
            raise ValueError(
                f"the reach map's option(s) {', '.join(foreign)} do not apply to {env}'s "
                "hierarchical map; leave them out"
            )
        if foreign:
            raise ValueError(
                f"{', '.join(foreign)} is for the grasp envs ({', '.join(GRASP_ENV_IDS)}), not "
                f"{env}; leave it out"
            )
        map_options = {k: v for k, v in options.items() if k in mine}
        return cls(**run, map=from_run_settings(kind, map_options))

    @classmethod
    def from_stored(cls, stored: dict[str, Any]) -> RunConfig:
        """The configuration as a checkpoint stored it; older checkpoints hold the image size
        as ``image_size`` = [height, width]."""
        stored = dict(stored)
        if "image_size" in stored:
            stored["height"], stored["width"] = stored.pop("image_size")
        env = stored.get("env")
        if env in GRASP_ENV_IDS:
            if grasp_task(env).default_orientations is not None:  # the arm has ranges
                stored.setdefault("orientations", FIRST_ORIENTATIONS)
            stored.setdefault("training_pairs", FIRST_TRAINING_PAIRS)
        return cls.of(**stored)

    def settings(self) -> dict[str, Any]:
        """Every setting of the run, flat, as :meth:`of` takes them: the fields, and the map's
        run options by the names and spellings a run gives them (on a grasp env also
        ``GRASP_RUN_ENTRIES``)."""
        own = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "map"}
        config = self.map
        extra = GRASP_RUN_ENTRIES if self.grasp else {}
        return own | extra | run_defaults(type(config)) | run_entries(config)

    def to_stored(self) -> dict[str, Any]:
        """The settings as a checkpoint stores them (:meth:`from_stored` reads them back),
        those of ``ADDED_LATER`` left out while they hold its value, so that runs without them
        keep their files and sweep cells their names."""
        return {
            k: v
            for k, v in self.settings().items()
            if not (k in ADDED_LATER and ADDED_LATER[k] == v)
        }

    def make_env(self, stream: str = "training") -> gym.Env:
        """The run's env, drawing its targets from ``stream`` of the run's seed
        (:mod:`envs.harness.streams`): the training targets, or the held-out ``"evaluation"``
        ones that training never draws."""
        pose = {"orientations": self.orientations} if self.grasp else {}
        env = gym.make(
            self.env,
            sensing=self.sensing,
            control=self.control,
            width=self.width,
            height=self.height,
            **pose,
        )
        if stream == "training":
            env.reset(seed=self.seed)  # the runs' first target, as before streams existed
        else:
            seed_env(env, self.seed, stream)
        return env


def initial_grasp_map(config: RunConfig, env: gym.Env) -> HierarchicalSOM:
    """A fresh hierarchical map for a grasp env from what a robot knows: its joint ranges
    (``GraspEnv.learner_bounds``), the taught pose (the task's keyframe: ``ready``, a generated
    arm's ``grasp_ready``) at every leaf, and the image size (the map spreads its position nodes
    over the image), as the grasp-learning study builds it."""
    base = env.unwrapped
    joints = [base.model.joint(f"joint{i + 1}").qposadr[0] for i in range(base.joints)]
    ready = base.model.key(base.markers.ready_key).qpos[joints]
    lower, upper = base.learner_bounds()
    return HierarchicalSOM(
        lower,
        upper,
        ready.copy(),
        config.map,
        rng=np.random.default_rng(config.seed),
    )


def initial_map(config: RunConfig, env: gym.Env, **options: Any) -> VisuomotorSOM:
    """A fresh map for ``env`` from what a robot knows before it learns: w spread over the box
    of the first INIT_TARGETS targets its cameras see, every θ_r at the taught pose (the MJCF
    keyframe ``ready``), within the joint ranges. Neither the kinematics, an IK nor the camera
    model is used.

    The targets are drawn with a generator of seed + INIT_SEED_OFFSET, and the env's own
    generator is restored afterwards, so the training targets do not change. ``options`` are
    map options beyond the run's (``SOMConfig`` fields, e.g. ``continual``).
    """
    base = env.unwrapped
    saved = base.np_random
    base.np_random = np.random.default_rng(config.seed + INIT_SEED_OFFSET)
    pixels = np.zeros((INIT_TARGETS, 4))
    try:
        for i in range(INIT_TARGETS):
            base.reset()
            pixels[i] = base.sensed_target()
    finally:
        base.np_random = saved
    seen = pixels[np.all(np.isfinite(pixels), axis=1)]  # (n, 4)
    if len(seen) < 2:
        raise RuntimeError(
            f"{config.env}: the cameras saw {len(seen)} of {INIT_TARGETS} targets; check the "
            "scene's cameras (sensing needs the targets in view)"
        )
    joints = [base.model.joint(f"joint{i + 1}").qposadr[0] for i in range(base.joints)]
    ready = base.model.key(base.markers.ready_key).qpos[joints]
    return VisuomotorSOM(
        base.joint_lower,
        base.joint_upper,
        SOMConfig.of(config.map, **options),
        rng=np.random.default_rng(config.seed),
        input_low=seen.min(axis=0),
        input_high=seen.max(axis=0),
        theta_init=ready.copy(),
    )


def _interval(checkpoint_every: int) -> int:
    """``checkpoint_every`` checked: trials between checkpoints, an integer >= 1."""
    if isinstance(checkpoint_every, bool) or not isinstance(checkpoint_every, int):
        raise ValueError(f"checkpoint_every is {checkpoint_every!r}; it takes an integer >= 1")
    if checkpoint_every < 1:
        raise ValueError(f"checkpoint_every is {checkpoint_every}; it takes an integer >= 1")
    return checkpoint_every


class Trainer:
    """Runs ``config.trials`` training trials, evaluating every ``eval_every`` trials; with
    ``config.workers`` >= 2 in rounds of ROUND_TRIALS trials collected by that many worker
    processes (``envs.harness.workers``) or Ray actors (``address``), each round learned in the
    order of its trials.

    The folder ``out`` is locked while the trainer exists (``close()`` releases it) and holds
    the checkpoint unit (``checkpoint.npz``: map, trainer state, simulation state, env generator,
    metrics position) and ``metrics.jsonl`` (one held-out evaluation per row).

    Args:
        config: the run; out: its folder; force: start over in a folder that holds a run;
        address: run the workers as Ray actors on the Ray cluster at this address
            (``envs.harness.ray_workers``: ``auto``, ``HOST:PORT`` or ``local``); None: local
            processes. The same map either way: the address is not stored with the run.
    Raises:
        RunFolderError: another process writes to ``out``, or ``out`` holds a run and not
            ``force``.
        AddressError: ``address`` is not a Ray address, or the run has 1 worker.
        RayUnavailableError: ``address`` without Ray installed.
    """

    def __init__(
        self,
        config: RunConfig,
        out: Path,
        force: bool = False,
        checkpoint_every: int = CHECKPOINT_EVERY,
        address: str | None = None,
    ) -> None:
        folder = RunFolder(out)
        try:
            folder.claim_fresh((CHECKPOINT_FILE, OLD_CHECKPOINT_FILE, METRICS_FILE), force)
            self._build(config, folder, address)
            self.pending_eval = True  # the evaluation of the untrained map, trial 0
            self.checkpoint_every = _interval(checkpoint_every)
            self.save()  # from here on every kill can be resumed
        except BaseException:
            folder.release()
            raise

    def _build(self, config: RunConfig, folder: RunFolder, address: str | None) -> None:
        if address is not None:  # checked before any work
            self.make_pool = ray_pools(address, config.workers)
        self.config, self.folder, self.out = config, folder, folder.path
        self.env = config.make_env()
        self.som: Map = (
            initial_grasp_map(config, self.env) if config.grasp else initial_map(config, self.env)
        )
        self.trial, self.metrics_rows, self.pending_eval = 0, 0, False
        self.running = {"coarse_mm": float("nan"), "fine_mm": float("nan")}
        self.checkpoint_every = CHECKPOINT_EVERY
        self.pool: RoundPool | None = None  # the workers, from the first round
        self.spent: Collected | None = None  # what the workers spent, kept when they are closed
        self.learner_seconds = 0.0  # spent learning from the workers' trials

    # -- checkpoints ---------------------------------------------------------------------------

    @staticmethod
    def stored_config(out: Path) -> RunConfig:
        """The configuration of the run saved in ``out``, its run state checked
        (CheckpointError if there is none, or either is damaged)."""
        path = checkpoint_path(out)
        if not path.is_file():
            raise CheckpointError(f"{path}: no checkpoint to resume; train without --resume")
        run = read_unit(path)[0]
        RunState.from_entries(run, str(path))
        try:
            return RunConfig.from_stored(run["config"])
        except (TypeError, ValueError) as exc:
            raise CheckpointError(f"{path}: the run's configuration is damaged ({exc})") from exc

    @classmethod
    def resume(
        cls,
        out: Path,
        trials: int | None = None,
        checkpoint_every: int | None = None,
        address: str | None = None,
    ) -> Trainer:
        """Continue the run saved in ``out``; ``trials`` extends (or shortens) its end,
        ``checkpoint_every`` replaces its interval between checkpoints (None: the run's own),
        ``address`` runs its workers as Ray actors (as in the constructor; a run continues bit
        for bit wherever its workers ran before).

        Every entry of the checkpoint is checked (the run state, the map, the simulation state,
        against each other and against ``metrics.jsonl``) before ``metrics.jsonl`` is cut back
        to the rows the checkpoint counts, the only write (CheckpointError, the folder as it
        was)."""
        trainer = cls.__new__(cls)
        folder = RunFolder(out)
        try:
            path = checkpoint_path(folder.path)
            config = stored = cls.stored_config(out)
            run, sim_state = read_unit(path)
            state = RunState.from_entries(run, str(path))
            if trials is not None:
                if trials < state.trial:
                    raise CheckpointError(
                        f"--trials {trials} is below the {state.trial} trials this run has done"
                    )
                config = replace(config, trials=trials)
            trainer._build(config, folder, address)
            wanted = identity(trainer.env, config.lattice)
            check_identity(path, unit_identity(run, str(path)), wanted, tuple(wanted))
            trainer.som = load_map(path)
            check_map_fits(path, trainer.som, trainer.env)
            lattice = {"lattice": list(trainer.som.lattice)}
            check_identity(path, lattice, {"lattice": list(config.lattice)}, ("lattice",))
            state.check_fits(str(path), stored.trials, stored.eval_every, trainer.som.t)
            metrics = folder.path / METRICS_FILE
            check_metrics(
                metrics, state.metrics_rows, state.trial, state.pending_eval, stored.eval_every
            )
            trainer._take(state, path)
            try:
                set_sim_state(trainer.env, sim_state)
            except CheckpointError as exc:
                raise CheckpointError(f"{path}: {exc}") from None
            if checkpoint_every is not None:
                trainer.checkpoint_every = _interval(checkpoint_every)
            truncate_metrics(metrics, trainer.metrics_rows)
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            folder.release()
            if isinstance(exc, (CheckpointError, AddressError)):
                raise
            raise CheckpointError(f"{out}: the run's state is damaged ({exc!r})") from exc
        except BaseException:
            folder.release()
            raise
        return trainer

    def _take(self, state: RunState, path: Path) -> None:
        """Continue from ``state`` (checked), the env's generator set to its ``env_rng``."""
        generator = self.env.unwrapped.np_random.bit_generator
        kind = type(generator).__name__
        if state.env_rng["bit_generator"] != kind:
            raise CheckpointError(
                f"{path}: the run state's env_rng is of {state.env_rng['bit_generator']!r}, this "
                f"env's generator is {kind!r}; the file is damaged"
            )
        try:
            generator.state = dict(state.env_rng)
        except (TypeError, ValueError, OverflowError) as exc:
            raise CheckpointError(
                f"{path}: the run state's env_rng is damaged ({type(exc).__name__}: {exc})"
            ) from None
        self.trial, self.running = state.trial, dict(state.running)
        self.metrics_rows, self.pending_eval = state.metrics_rows, state.pending_eval
        self.checkpoint_every = state.checkpoint_every

    def run_state(self) -> RunState:
        """Where the run stands (what :meth:`save` stores besides the configuration)."""
        return RunState(
            trial=self.trial,
            running=dict(self.running),
            metrics_rows=self.metrics_rows,
            pending_eval=self.pending_eval,
            env_rng=self.env.unwrapped.np_random.bit_generator.state,
            checkpoint_every=self.checkpoint_every,
        )

    def save(self) -> None:
        """Write the checkpoint unit (atomically: a kill leaves the previous one intact)."""
        run = {
            "config": self.config.to_stored(),
            "identity": identity(self.env, self.config.lattice),
            **self.run_state().to_entries(),
        }
        write_unit(checkpoint_path(self.out), self.som, run, get_sim_state(self.env))

    # -- the loop ------------------------------------------------------------------------------

    def run(
        self,
        checkpoint_every: int | None = None,
        progress: Callable[[int, dict[str, float]], None] | None = None,
        stop: SignalStop | None = None,
    ) -> None:
        """Train until ``config.trials``; checkpoint every ``checkpoint_every`` trials (None: the
        run's own interval; a new one is stored with the run) and at the end.

        SIGINT and SIGTERM (noted by ``stop``, or by a :class:`SignalStop` installed here) let
        the current trial finish, abandon a held-out evaluation or a round of the workers
        (redone on resume), save and raise :class:`StopRequested`. Any other exception leaves
        the last checkpoint as it is.
        """
        if checkpoint_every is not None:
            self.checkpoint_every = _interval(checkpoint_every)
        checkpoint_every = self.checkpoint_every
        if stop is None:
            with SignalStop() as own:
                return self.run(checkpoint_every, progress, own)
        try:
            while True:
                if self.pending_eval:
                    row = self.held_out(stop.check)  # abandoned before a trial on a signal
                    self._log(row)
                    self.pending_eval = False
                    if self.trial == self.config.trials or self.trial % checkpoint_every == 0:
                        self.save()
                if self.trial >= self.config.trials:
                    break
                stop.check()
                before = self.trial
                if self.config.workers == 1:
                    self.train_one()
                else:
                    self.train_round(stop.check)
                self.pending_eval = (
                    self.trial % self.config.eval_every == 0 or self.trial == self.config.trials
                )
                crossed = self.trial // checkpoint_every != before // checkpoint_every
                if crossed and (self.config.workers > 1 or not self.pending_eval):
                    self.save()
                if progress is not None:
                    progress(self.trial, self.running)
        except StopRequested:
            self.som.reset()  # as after every evaluation; the next trial resets it anyway
            self.save()
            raise
        self.save()

    def train_one(self) -> Trial:
        """One trial in this process's env, learned at once; returns it."""
        pairs = self.config.training_pairs or 1  # the reach runs: one pair
        trial = run_trial(
            self.env, self.som, fine_moves=pairs, keep_arm=self.config.keep_arm, explore=True
        )
        self._learn(trial, pairs)
        return trial

    def train_round(self, check: Callable[[], None] = lambda: None) -> None:
        """One round (``envs.harness.workers.round_end``): its trials collected by the
        workers with the map as it is now, then learned in their order. ``check`` is called
        while the workers run (it may raise to abandon the round, which leaves the map as it
        was: a resumed run redoes the round)."""
        config = self.config
        pairs = config.training_pairs or 1
        end = round_end(self.trial, config.trials, config.eval_every, self.round_trials)
        trials = self._workers().collect(self.som, self.trial, end, pairs, check)
        start = time.perf_counter()
        for trial in trials:
            self._learn(trial, pairs, stale=True)
        self.learner_seconds += time.perf_counter() - start

    def _workers(self) -> RoundPool:
        """The run's workers (``workers`` >= 2), started at their first task."""
        if self.pool is None:
            self.pool = self.make_pool(self.config, self.config.workers)
            self.spent = self.pool.spent
        return self.pool

    #: Trials of a round with workers (a constant of the code: a checkpoint does not store it).
    round_trials = ROUND_TRIALS
    #: The workers of a run with ``workers`` >= 2: local processes; Ray actors with an
    #: ``address`` (``ray_pools``; ``InProcessPool`` runs the same rounds in this process, for
    #: measurements and tests).
    make_pool: Callable[[RunConfig, int], RoundPool] = WorkerPool

    def _learn(self, trial: Trial, pairs: int, stale: bool = False) -> None:
        """Learn from ``trial`` (``pairs`` pairs of its moves; ``stale``: the map of a round's
        start made its moves) and count it."""
        learn_from(self.som, trial, pairs, stale)
        self.trial += 1
        for key, k in (("coarse_mm", 0), ("fine_mm", 1)):
            if len(trial.distances) > k:
                new = trial.distances[k] * 1e3
                old = self.running[key]
                self.running[key] = new if np.isnan(old) else old + RUNNING_WEIGHT * (new - old)

    def held_out(self, check: Callable[[], object] | None = None) -> dict[str, Any]:
        """Evaluate on the fixed held-out targets (without learning); ``check`` is called
        before every trial, or with workers while they run (it may raise to abandon the
        evaluation). With workers (``workers`` >= 2) they share the trials out: the same row."""
        config = self.config
        if config.workers > 1:
            trials = self._workers().evaluate(
                self.som, config.eval_trials, config.fine_moves, check or (lambda: None)
            )
            reach = self.env.unwrapped.reach
            result = evaluation_of(trials, config.fine_moves, reach, math.nan, self.som.recovers)
        else:
            env = config.make_env("evaluation")
            controller = self.som if check is None else Ticking(self.som, check)
            try:
                result = evaluate(env, controller, config.eval_trials, config.fine_moves)
            finally:
                env.close()
                self.som.reset()
        summary = result.summary()
        del summary["microseconds_per_query"]  # wall time: would make reruns differ
        return {"trial": self.trial, "learned": self.som.t, **summary}

    def _log(self, row: dict[str, Any]) -> None:
        with open(self.out / METRICS_FILE, "a") as f:
            f.write(json.dumps(row, allow_nan=False) + "\n")
        self.metrics_rows += 1

    def close(self) -> None:
        if self.pool is not None:
            self.pool.close()
            self.spent, self.pool = self.pool.spent, None
        self.env.close()
        self.folder.release()
