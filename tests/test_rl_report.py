"""The map-vs-RL report (``envs.studies.rl_report``, ``scripts/compare_rl.py --report-only``) from
hand-set curves: every cell written here from the curves, not from the code."""

from __future__ import annotations

import json
import math
import subprocess
import sys

from envs.studies.rl_comparison import Curve
from envs.studies.rl_report import table

from helpers import SCRIPTS, assert_drawn_png

STEPS = [100, 1000, 10000]
SCRIPT = SCRIPTS / "compare_rl.py"


def _curves() -> list[Curve]:
    # mean over seeds: 30, 7.5, 2 mm (10 mm first at 1,000 steps, 5 mm at 10,000, 1 mm never)
    a = Curve("map", 0, STEPS, [0.020, 0.005, 0.001], [0.010, 0.002, 0.0005], 2.0)
    b = Curve("map", 1, STEPS, [0.040, 0.010, 0.003], [0.020, 0.004, 0.0015], 4.0)
    c = Curve("sac", 0, STEPS, [0.300, 0.200, 0.100], [0.250, 0.150, 0.090], 100.0)
    return [a, b, c]


def test_table_cells():
    lines = table(_curves()).splitlines()
    assert lines[0].startswith("| method | seeds | env steps | mean final [mm] |")
    cells = [line.strip("| ").split(" | ") for line in lines[2:]]
    # seeds 2; final 1 and 3 mm -> 2.00 ± sd 1.41; median (0.5 + 1.5) / 2 = 1.00; 3 ms / step
    assert cells[0] == ["visuomotor map", "2", "10,000", "2.00 ± 1.41", "1.00", "1,000", "10,000",
                        "not reached", "0.30"]  # fmt: skip
    assert cells[1] == ["SAC", "1", "10,000", "100.00", "90.00", "not reached", "not reached",
                        "not reached", "10.00"]  # fmt: skip


def test_report_only_rewrites_table_and_plot(tmp_path):
    with open(tmp_path / "curves.jsonl", "w") as f:
        for c in _curves():
            row = {"env": "RiacsReach-v0", "sensing": "project", "control": "kinematic"}
            f.write(json.dumps({**row, **c.to_json()}) + "\n")
    args = ["--report-only", "--targets", "10", "--out", str(tmp_path)]
    subprocess.run([sys.executable, str(SCRIPT), *args], check=True, capture_output=True)
    text = (tmp_path / "table.md").read_text()
    sections = text.split("### ")[1:]
    assert len(sections) == 1  # one env and setting in the curves
    title, *rows = [line for line in sections[0].splitlines() if line]
    assert title == "RiacsReach-v0 (project, kinematic), 10 held-out targets"
    cells = [row.strip("| ").split(" | ") for row in rows[2:]]
    # From the curves by hand: the map's final means 1 and 3 mm (mean 2, sd √2), medians 0.5 and
    # 1.5 mm; 2 s and 4 s of training over 10,000 steps: 0.3 ms per step. SAC: one seed.
    sd = math.sqrt(((1 - 2) ** 2 + (3 - 2) ** 2) / (2 - 1))
    assert cells[0][:5] == ["visuomotor map", "2", "10,000", f"2.00 ± {sd:.2f}", "1.00"]
    assert cells[0][-1] == "0.30"
    assert cells[1][:5] == ["SAC", "1", "10,000", "100.00", "90.00"] and cells[1][-1] == "10.00"
    assert_drawn_png(tmp_path / "RiacsReach-v0_project_kinematic.png")
