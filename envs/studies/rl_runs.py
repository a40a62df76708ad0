"""A long map-vs-RL comparison as a list of resumable runs, one folder each.

A run is one (env, method, variant, episode length, seed) at one setting, budget, list of
checkpoints and number of held-out targets. Its folder holds ``curve.json`` (the spec and the
curve so far, rewritten atomically after every checkpoint's evaluation, ``"done"`` once the last
is in) and, for SB3 methods, the model of its last checkpoint with its replay buffer or PPO's
normalisation (named in ``model.json``; the replay buffer is removed when the run is done).
Running the list again skips the finished runs and continues an interrupted one from its last
saved model; each folder is locked while a process runs it, so two processes given the same
list share it out. A resumed SB3 run does not
repeat the steps done, but it is not the same as an uninterrupted one: the random generators
(torch's, numpy's global one that SB3 samples its replay buffer with, the training env's) and
the training env's episode in progress are not saved; the resumed env draws its targets from
the seed plus the steps done. A map run (seconds long) that was interrupted starts again.
"""

from __future__ import annotations

import json
import pickle
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from envs.harness.run_folder import RunFolder, RunFolderError, write_json
from envs.studies.rl_comparison import VARIANT_METHODS, Curve, run_method
from learners.persistence import write_atomic

CURVE_FILE, MODEL_STATE_FILE = "curve.json", "model.json"
RUNS_FOLDER = "runs"  # under the comparison's output folder


class RunSpecError(ValueError):
    """A run folder holds a run of other settings than the ones asked for."""


@dataclass(frozen=True)
class RunSpec:
    """One run of the comparison; every field is part of its identity (and its folder)."""

    env: str
    sensing: str
    control: str
    method: str
    variant: str
    episode_steps: int
    seed: int
    budget: int
    points: tuple[int, ...]
    targets: int

    @property
    def folder(self) -> Path:
        """Relative folder: setting, method/variant/episode length, seed."""
        return (
            Path(f"{self.env}_{self.sensing}_{self.control}")
            / f"{self.method}-{self.variant}-{self.episode_steps}move"
            / f"seed{self.seed}"
        )

    def to_json(self) -> dict[str, Any]:
        return {**asdict(self), "points": list(self.points)}


def run_list(
    envs: list[str],
    setting: dict[str, str],
    methods: list[str],
    variants: list[str],
    episode_steps: list[int],
    seeds: list[int],
    budget: int,
    points: list[int],
    targets: int,
) -> list[RunSpec]:
    """Every combination, seeds outermost after env and episode length (so a partial list has
    all methods at the first seeds); variants that do not apply to a method are left out."""
    return [
        RunSpec(
            env,
            setting["sensing"],
            setting["control"],
            method,
            variant,
            steps,
            seed,
            budget,
            tuple(points),
            targets,
        )
        for env in envs
        for steps in episode_steps
        for seed in seeds
        for method in methods
        for variant in variants
        if method in VARIANT_METHODS[variant]
    ]


class Store:
    """The saved state of one SB3 run in its folder (see the module docstring).

    A checkpoint's model and replay buffer (or normalisation) go to files named by its step
    count; ``model.json`` is then rewritten to name them (the commit: a save killed half-way
    leaves the previous one in force) and older files are removed.
    """

    def __init__(self, folder: Path, spec: RunSpec) -> None:
        self.folder, self.spec = folder, spec

    def read(self) -> dict[str, Any] | None:
        """``curve.json``, or None; refuses one written for another spec."""
        saved = _read_json(self.folder / CURVE_FILE)
        if saved is not None and saved["spec"] != self.spec.to_json():
            differs = _diff(saved["spec"], self.spec)
            raise RunSpecError(
                f"{self.folder} holds a run with other settings ({differs}); use the same "
                "options or another --out"
            )
        return saved

    def resume(self, method: str, venv) -> tuple[Any, Any, Curve] | None:
        """(model, vec env, curve) at the last saved model, or None to start afresh. The curve
        keeps the checkpoints evaluated up to that model and its training time."""
        from stable_baselines3 import PPO, SAC

        saved, model_state = self.read(), _read_json(self.folder / MODEL_STATE_FILE)
        if saved is None or model_state is None:
            return None
        if method == "ppo":
            with open(self.folder / model_state["extra"], "rb") as f:
                normalize = pickle.load(f)  # VecNormalize without its venv
            normalize.set_venv(venv)
            venv = normalize
            model = PPO.load(self.folder / model_state["model"], env=venv, device="cpu")
        else:
            model = SAC.load(self.folder / model_state["model"], env=venv, device="cpu")
            model.load_replay_buffer(self.folder / model_state["extra"])
        curve = Curve(**saved["curve"])
        keep = sum(s <= model.num_timesteps for s in curve.steps)
        curve = truncated(curve, keep)
        curve.train_seconds = model_state["train_seconds"]
        return model, venv, curve

    def save_model(self, model, venv, train_seconds: float) -> None:
        """The model after training to a checkpoint, before its evaluation."""
        steps = model.num_timesteps
        names = {"model": f"model_{steps}.zip", "extra": f"vecnormalize_{steps}.pkl"}
        write_atomic(self.folder / names["model"], model.save)
        if hasattr(model, "replay_buffer"):
            names["extra"] = f"replay_buffer_{steps}.pkl"
            write_atomic(self.folder / names["extra"], model.save_replay_buffer)
        else:
            write_atomic(self.folder / names["extra"], lambda f: pickle.dump(venv, f))
        state = {**names, "steps": steps, "train_seconds": train_seconds}
        write_json(self.folder / MODEL_STATE_FILE, state)
        for old in self.folder.glob("*_*.*"):
            if old.name not in names.values():
                old.unlink()

    def save_curve(self, curve: Curve, done: bool = False) -> None:
        """The curve after a checkpoint's evaluation (the model saved before it)."""
        data = {"spec": self.spec.to_json(), "done": done, "curve": curve.to_json()}
        write_json(self.folder / CURVE_FILE, data)

    def finish(self, curve: Curve) -> None:
        """Mark the run done and drop its replay buffer (the last model stays)."""
        self.save_curve(curve, done=True)
        state = _read_json(self.folder / MODEL_STATE_FILE)
        if state is not None and state["extra"].startswith("replay_buffer"):
            (self.folder / state["extra"]).unlink(missing_ok=True)


def run(spec: RunSpec, out: Path) -> Curve | None:
    """Run ``spec`` in ``out/runs/<spec.folder>``, or continue it there; returns its curve, or
    None when another process holds the folder."""
    folder = out / RUNS_FOLDER / spec.folder
    try:
        lock = RunFolder(folder)
    except RunFolderError:
        return None
    try:
        store = Store(folder, spec)
        saved = store.read()
        if saved is not None and saved["done"]:
            return Curve(**saved["curve"])
        curve = run_method(
            spec.method,
            variant=spec.variant,
            store=None if spec.method == "map" else store,
            env_id=spec.env,
            env_kwargs={"sensing": spec.sensing, "control": spec.control},
            seed=spec.seed,
            budget=spec.budget,
            points=list(spec.points),
            targets=spec.targets,
            episode_steps=spec.episode_steps,
        )
        store.finish(curve)
        return curve
    finally:
        lock.release()


def saved_runs(out: Path) -> Iterator[tuple[RunSpec, Curve, bool]]:
    """Every run under ``out/runs`` with at least one checkpoint: spec, curve so far, whether it
    is finished; in folder order."""
    for path in sorted((out / RUNS_FOLDER).glob(f"**/{CURVE_FILE}")):
        saved = _read_json(path)
        if saved is not None and saved["curve"]["steps"]:
            spec = {**saved["spec"], "points": tuple(saved["spec"]["points"])}
            yield RunSpec(**spec), Curve(**saved["curve"]), saved["done"]


def truncated(curve: Curve, keep: int) -> Curve:
    """``curve`` with its first ``keep`` checkpoints."""
    data = curve.to_json()
    for name in ("steps", "mean_m", "median_m"):
        data[name] = data[name][:keep]
    data["success"] = {k: v[:keep] for k, v in data["success"].items()}
    return Curve(**data)


def _read_json(path: Path) -> dict[str, Any] | None:
    return json.loads(path.read_text()) if path.is_file() else None


def _diff(saved: dict[str, Any], spec: RunSpec) -> str:
    asked = spec.to_json()
    return ", ".join(f"{k} {saved.get(k)!r} there, {v!r} asked" for k, v in asked.items()
                     if saved.get(k) != v)  # fmt: skip
