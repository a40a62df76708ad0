"""Run-state edits through the real programs: a tiny run's checkpoint rewritten (valid CRCs)
with one entry of its run state or its simulation state set to a wrong type, a negative or
out-of-range value, one that disagrees with another entry, NaN, 2**200, or left out; then
``train.py --resume`` and ``evaluate.py --run`` in child processes. Every edit is refused in
one line naming the entry, with the run folder unchanged byte for byte, or loads identically:
the resumed run ends with the map and ``metrics.jsonl`` of the unedited run's resume, the
evaluation prints the unedited run's table. No tracebacks, no hangs. ``make soak``
(``VISUOMOTOR_SOAK=1``) draws 60 edits, ``make test`` 20.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import envs  # noqa: F401  (registers the envs)
from envs.harness.checkpoint import CHECKPOINT_FILE, KIND, sim_state_parts
from envs.harness.run_folder import METRICS_FILE
from envs.harness.training import RunConfig
from learners.persistence import load_npz, save_npz
from learners.som.controller import FORMAT_VERSION, VisuomotorSOM

from helpers import run_script

EDITS = 60 if os.environ.get("VISUOMOTOR_SOAK") else 20
#: s: a tiny resume takes seconds on an idle machine; only a hang comes near this.
HANG_TIMEOUT = 300.0
#: A run of 8 trials (held-out rows at trials 0, 4, 8), resumed to 12.
TINY = ["--lattice", "3x2x2", "--eval-every", "4", "--eval-trials", "3"]
RESUME = ["--resume", "--trials", "12"]
EVALUATE = ["--targets", "2", "--no-plots"]
#: A one-line message, the run folder's path left out, is at most this long.
MESSAGE_CHARS = 200
MISSING = object()  # an entry left out

#: A value of each kind of damage (None: the kind is made per entry, see ``_value``).
KINDS = ("text", "list", "negative", "out of range", "inconsistent", "nan", "2**200", "missing")
#: Entries of the run state (a path into its JSON), with the value that is out of range for
#: them, one that disagrees with another entry, and the words a refusal must contain (any).
RUN_ENTRIES: dict[tuple[str, ...], tuple[Any, Any, tuple[str, ...]]] = {
    ("trial",): (10**9, 7, ("trial",)),  # 7: below the map's 8 learned trials
    ("metrics_rows",): (10**9, 2, ("metrics_rows", "rows")),  # 2: the schedule gives 3
    ("pending_eval",): (2, True, ("pending_eval", "metrics_rows")),  # its row is logged
    ("running",): ({}, {"coarse_mm": 1.0}, ("running",)),
    ("running", "coarse_mm"): (1e300, 1, ("running",)),  # 1: an int, not a float
    ("running", "fine_mm"): (1e6, None, ("running",)),
    ("env_rng",): ({}, {"bit_generator": "MT19937"}, ("env_rng",)),
    ("env_rng", "bit_generator"): ("Philox", "MT19937", ("env_rng",)),
    ("env_rng", "state", "state"): (2**128, 1.5, ("env_rng",)),
    ("env_rng", "state", "inc"): (2**128, 2, ("env_rng",)),  # PCG64's increment is odd
    ("env_rng", "has_uint32"): (7, True, ("env_rng",)),
    ("env_rng", "uinteger"): (2**32, 0.5, ("env_rng",)),
    ("checkpoint_every",): (0, True, ("checkpoint_every",)),
    ("identity",): ({}, {"robot": "puma560"}, ("identity", "trained for")),
    ("identity", "lattice"): ([100_000] * 3, [4, 4, 4], ("lattice",)),
    ("identity", "joints"): (6, 2, ("joints",)),
    ("config", "trials"): (0, 5, ("trials", "trial")),  # 5: below the 8 done
    ("config", "eval_every"): (0, 3, ("eval_every", "metrics_rows", "rows")),
}
#: Parts of the simulation state (``sim_state_parts``), with the words a refusal must contain.
SIM_PARTS = {"time": ("time",), "qpos": ("qpos",), "qvel": ("qvel",), "ctrl": ("ctrl",),
             "mocap_pos": ("mocap_pos",), "whole": ("simulation state", "sim_state")}  # fmt: skip


def _value(kind: str, out_of_range: Any, inconsistent: Any) -> Any:
    return {"text": "x", "list": [1], "negative": -1, "out of range": out_of_range,
            "inconsistent": inconsistent, "nan": float("nan"), "2**200": 2**200,
            "missing": MISSING}[kind]  # fmt: skip


def _set(tree: dict, keys: tuple[str, ...], value: Any) -> None:
    for key in keys[:-1]:
        tree = tree[key]
    if value is MISSING:
        tree.pop(keys[-1])
    else:
        tree[keys[-1]] = value


def _sim_edit(part: str, kind: str) -> Callable[[np.ndarray, dict[str, slice]], Any]:
    """A change of ``part`` of the simulation state (its first number; ``whole``: the array)."""
    if part == "whole":
        return {"text": lambda s, p: np.array("x"), "list": lambda s, p: s[:-1],
                "negative": lambda s, p: -s, "out of range": lambda s, p: s * 1e6,
                "inconsistent": lambda s, p: s.astype(np.float32),
                "nan": lambda s, p: s * np.nan, "2**200": lambda s, p: s.astype(np.int64),
                "missing": lambda s, p: MISSING}[kind]  # fmt: skip
    value = {"text": np.inf, "list": -np.inf, "negative": -1.0, "out of range": 1e6,
             "inconsistent": 1e3 if part == "qvel" else 2.0 * np.pi + 4.0,
             "nan": np.nan, "2**200": 2.0**200, "missing": 1e300}[kind]  # fmt: skip

    def edit(state: np.ndarray, parts: dict[str, slice]) -> np.ndarray:
        state[parts[part].start] = state[parts[part].start] + value if part == "qpos" else value
        return state

    return edit


def _edits() -> list[tuple[str, tuple[str, ...], Callable]]:
    """Every (entry, kind) pair as (name, words a refusal names, change(run, sim, parts))."""
    edits = []
    for keys, (out_of_range, inconsistent, words) in RUN_ENTRIES.items():
        for kind in KINDS:
            value = _value(kind, out_of_range, inconsistent)

            def change(run, sim, parts, keys=keys, value=value):
                _set(run, keys, value)
                return run, sim

            edits.append((f"{'.'.join(keys)} {kind}", words, change))
    for part, words in SIM_PARTS.items():
        for kind in KINDS:
            sim_edit = _sim_edit(part, kind)

            def change(run, sim, parts, sim_edit=sim_edit):
                return run, sim_edit(sim.copy(), parts)

            edits.append((f"sim_state.{part} {kind}", words, change))
    return edits


def _rewrite(path: Path, change: Callable, parts: dict[str, slice]) -> None:
    """The checkpoint ``path`` with ``change(run, sim_state, parts)`` applied, valid CRCs."""
    config, arrays = load_npz(path, KIND, FORMAT_VERSION)
    run, sim = change(json.loads(str(arrays.pop("run"))), arrays.pop("sim_state"), parts)
    arrays["run"] = np.array(json.dumps(run))
    if sim is not MISSING:
        arrays["sim_state"] = sim
    save_npz(path, KIND, FORMAT_VERSION, config, arrays)


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def _ending(folder: Path) -> tuple[Any, ...]:
    """What a resumed run ends with: the map's arrays and the metrics log."""
    _, arrays = VisuomotorSOM.load(folder / CHECKPOINT_FILE).state()
    return (*(arrays[k].tobytes() for k in sorted(arrays)), (folder / METRICS_FILE).read_bytes())


def _evaluation(out: Path) -> list[dict[str, Any]]:
    """What ``evaluate.py`` found (evaluation.json's rows without the wall time per query)."""
    rows = json.loads((out / "evaluation.json").read_text())["controllers"]
    return [{k: v for k, v in row.items() if k != "microseconds_per_query"} for row in rows]


class Tally:
    """The outcomes of the programs' runs on the edited checkpoints."""

    def __init__(self) -> None:
        self.edits = self.tracebacks = self.hangs = 0
        self.refused = {"train": 0, "evaluate": 0}
        self.identical = {"train": 0, "evaluate": 0}
        self.failures: list[str] = []
        self.accepted: list[str] = []  # edits train.py --resume took

    def run(self, name: str, script: str, *args: str) -> subprocess.CompletedProcess | None:
        try:
            result = run_script(script, *args, timeout=HANG_TIMEOUT)
        except subprocess.TimeoutExpired:
            self.hangs += 1
            self.failures.append(f"{name}: {script}.py hung")
            return None
        if "Traceback" in result.stderr:
            self.tracebacks += 1
            self.failures.append(f"{name}: {script}.py: {result.stderr.splitlines()[-1]}")
            return None
        return result

    def refusal(self, name: str, script: str, result, folder: Path, before, words) -> None:
        lines = [line for line in result.stderr.splitlines() if "error:" in line]
        line = lines[0].replace(str(folder), "RUN") if len(lines) == 1 else ""
        if result.returncode != 2 or len(lines) != 1 or len(line) > MESSAGE_CHARS:
            self.failures.append(f"{name}: {script}.py: not one short line: {result.stderr!r}")
        elif not any(w in line for w in words):
            self.failures.append(f"{name}: {script}.py does not name {words}: {line}")
        elif _files(folder) != before:
            self.failures.append(f"{name}: {script}.py refused but changed the run folder")
        else:
            self.refused[script] += 1


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run")
    assert run_script("train", "--trials", "8", *TINY, "--out", str(out)).returncode == 0
    return out


def test_every_run_state_edit_is_refused_in_one_line_or_loads_identically(tiny_run, tmp_path):
    env = RunConfig.of(lattice=(3, 2, 2)).make_env()
    parts = sim_state_parts(env.unwrapped.model)
    env.close()
    reference = tmp_path / "reference"
    shutil.copytree(tiny_run, reference)
    evaluated = tmp_path / "eval"
    shown = run_script("evaluate", "--run", str(reference), *EVALUATE, "--out", str(evaluated))
    assert shown.returncode == 0, shown.stderr
    table = _evaluation(evaluated)
    assert run_script("train", "--out", str(reference), *RESUME).returncode == 0
    ending = _ending(reference)

    catalogue = _edits()
    rng = np.random.default_rng(37)
    tally = Tally()
    for index in rng.choice(len(catalogue), size=min(EDITS, len(catalogue)), replace=False):
        name, words, change = catalogue[index]
        folder = tmp_path / f"c{index}"
        shutil.copytree(tiny_run, folder)
        _rewrite(folder / CHECKPOINT_FILE, change, parts)
        tally.edits += 1
        before = _files(folder)
        shutil.rmtree(evaluated, ignore_errors=True)
        result = tally.run(name, "evaluate", "--run", str(folder), *EVALUATE, "--out",
                           str(evaluated))  # fmt: skip
        if result is not None and result.returncode == 0:
            if _evaluation(evaluated) == table:
                tally.identical["evaluate"] += 1
            else:
                tally.failures.append(f"{name}: evaluate.py loaded it and gave another evaluation")
        elif result is not None:
            tally.refusal(name, "evaluate", result, folder, before, words)
        result = tally.run(name, "train", "--out", str(folder), *RESUME)
        if result is not None and result.returncode == 0:
            if _ending(folder) == ending:
                tally.identical["train"] += 1
                tally.accepted.append(name)
            else:
                tally.failures.append(f"{name}: train.py --resume loaded it and ended elsewhere")
        elif result is not None:
            tally.refusal(name, "train", result, folder, before, words)
        shutil.rmtree(folder)
    print(
        f"{tally.edits} run-state edits; train.py --resume: {tally.refused['train']} refused, "
        f"{tally.identical['train']} resumed identically; evaluate.py --run: "
        f"{tally.refused['evaluate']} refused, {tally.identical['evaluate']} identical; "
        f"{tally.tracebacks} tracebacks, {tally.hangs} hangs; resumed: {', '.join(tally.accepted)}"
    )
    assert not tally.failures, "\n".join(tally.failures)
    assert tally.tracebacks == tally.hangs == 0
    assert tally.edits == min(EDITS, len(catalogue))
    assert tally.refused["train"] > tally.edits // 2  # the edits were real: most are refused
