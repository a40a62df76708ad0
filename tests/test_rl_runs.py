"""The comparison as a list of run folders (``envs.studies.rl_runs``) and its report with success
curves, variants and one-move episodes, from hand-set curves (no SB3 needed)."""

from __future__ import annotations

import numpy as np
import pytest

from envs.harness.run_folder import write_json
from envs.studies import rl_report, rl_runs
from envs.studies.rl_comparison import VARIANTS, Curve

from helpers import assert_drawn_png

SETTING = {"sensing": "project", "control": "kinematic"}
STEPS = [100, 1000, 10000]


def _spec(method: str, seed: int, variant: str = "zoo", episode_steps: int = 4) -> rl_runs.RunSpec:
    return rl_runs.RunSpec(
        "RiacsReach-v0", "project", "kinematic", method, variant, episode_steps, seed,
        STEPS[-1], tuple(STEPS), 4,
    )  # fmt: skip


def test_success_fractions_count_the_episodes_below_each_threshold():
    curve = Curve("sac", 0)
    curve.add(100, np.array([0.001, 0.006, 0.015, 0.030]))  # m
    curve.add(200, np.array([0.004, 0.004, 0.004, 0.050]))
    assert curve.success == {"5mm": [0.25, 0.75], "10mm": [0.5, 0.75], "20mm": [0.75, 0.75]}


def test_run_list_leaves_out_variants_that_do_not_apply():
    specs = rl_runs.run_list(
        ["RiacsReach-v0"], SETTING, ["map", "sac", "ppo"], ["zoo", "g2", "gamma0.5", "gamma0"],
        [4, 1], [0, 1], 1000, [500, 1000], 10,
    )  # fmt: skip
    names = [(s.episode_steps, s.seed, s.method, s.variant) for s in specs]
    per_seed = [
        ("map", "zoo"), ("sac", "zoo"), ("sac", "g2"), ("sac", "gamma0.5"), ("sac", "gamma0"),
        ("ppo", "zoo"),
    ]  # fmt: skip
    assert names == [(n, seed, *mv) for n in (4, 1) for seed in (0, 1) for mv in per_seed]
    assert str(specs[2].folder) == "RiacsReach-v0_project_kinematic/sac-g2-4move/seed0"


def test_a_folder_of_another_run_is_refused(tmp_path):
    spec = _spec("sac", 0)
    store = rl_runs.Store(tmp_path, spec)
    store.save_curve(Curve("sac", 0))
    assert rl_runs.Store(tmp_path, _spec("sac", 0)).read()["done"] is False  # the same reads
    other = rl_runs.RunSpec(**{**spec.to_json(), "points": (10000, 20000), "budget": 20000})
    with pytest.raises(rl_runs.RunSpecError, match="budget 10000 there, 20000 asked"):
        rl_runs.Store(tmp_path, other).read()


def _write_runs(out) -> None:
    """Finished: two map seeds, one SAC (γ 0.5), one one-move SAC. Under way: a second SAC (γ 0.5)
    seed at its 2nd checkpoint, and a SAC run with no checkpoint yet."""
    runs = [
        (_spec("map", 0), [0.020, 0.005, 0.001], [[0.0, 0.5, 1.0], [0.5, 1.0, 1.0]]),
        (_spec("map", 1), [0.040, 0.010, 0.003], [[0.0, 0.0, 0.5], [0.0, 0.5, 1.0]]),
        (_spec("sac", 0, "gamma0.5"), [0.300, 0.200, 0.100], [[0.0] * 3, [0.0, 0.0, 0.25]]),
        (_spec("sac", 0, "zoo", 1), [0.200, 0.050, 0.030], [[0.0] * 3, [0.0, 0.25, 0.25]]),
    ]
    for spec, mean, (five, ten) in runs:
        success = {"5mm": five, "10mm": ten, "20mm": [1.0, 1.0, 1.0]}
        curve = Curve(spec.method, spec.seed, STEPS, mean, mean, 10.0, spec.variant,
                      spec.episode_steps, success)  # fmt: skip
        write_json(out / "runs" / spec.folder / "curve.json",
                   {"spec": spec.to_json(), "done": True, "curve": curve.to_json()})  # fmt: skip
    under_way = _spec("sac", 1, "gamma0.5")
    success = {"5mm": [0.0, 0.0], "10mm": [0.0, 0.0], "20mm": [0.0, 0.5]}
    curve = Curve("sac", 1, STEPS[:2], [0.5, 0.1], [0.5, 0.1], 5.0, "gamma0.5", 4, success)
    data = {"spec": under_way.to_json(), "done": False, "curve": curve.to_json()}
    write_json(out / "runs" / under_way.folder / "curve.json", data)
    empty = _spec("sac", 2)
    data = {"spec": empty.to_json(), "done": False, "curve": Curve("sac", 2).to_json()}
    write_json(out / "runs" / empty.folder / "curve.json", data)


def test_report_from_run_folders_with_success_columns(tmp_path):
    _write_runs(tmp_path)
    text = rl_report.report(tmp_path, targets=4, table_at=[5000])
    first, second = text.split("### ")[1:]
    assert first.splitlines()[0].endswith("4 held-out targets, at 5,000 env steps")
    assert "at" not in second.splitlines()[0].split("targets")[1]  # the budget's table
    head = second.splitlines()[2]
    assert "| success < 5 mm | success < 10 mm | success < 20 mm |" in head
    rows = {r.strip("| ").split(" | ")[0]: r.strip("| ").split(" | ") for r in
            second.splitlines()[4:] if r.startswith("|")}  # fmt: skip
    # by hand: the map's 5 mm fractions at 10,000 steps 1.0 and 0.5 -> 75 %; 10 mm 1.0, 1.0
    assert rows["visuomotor map"][1:8] == ["2", "10,000", "2.00 ± 1.41", "2.00", "75%", "100%",
                                           "100%"]  # fmt: skip
    assert rows["SAC (1-move episodes)"][1:8] == ["1", "10,000", "30.00", "30.00", "0%", "25%",
                                                  "100%"]  # fmt: skip
    # γ 0.5: cut to the 2 checkpoints both seeds have: means 200 and 100 mm at 1,000 steps
    assert rows["SAC (γ 0.5)"][1:5] == ["2", "1,000", "150.00 ± 70.71", "150.00"]
    assert len(rows) == 3  # the run without a checkpoint is left out
    at = {r.strip("| ").split(" | ")[0]: r.strip("| ").split(" | ") for r in
          first.splitlines()[4:] if r.startswith("|")}  # fmt: skip
    # at 5,000 steps: the checkpoint at 1,000 (means 5 and 10 mm -> 7.50, sd 3.54)
    assert at["visuomotor map"][1:5] == ["2", "1,000", "7.50 ± 3.54", "7.50"]
    assert_drawn_png(tmp_path / "RiacsReach-v0_project_kinematic.png")


def test_figure_has_a_row_per_success_threshold_and_a_panel_per_episode_length():
    success = [{"5mm": [0.0] * 3, "10mm": ten, "20mm": [1.0] * 3} for ten in
               ([0.0, 0.5, 1.0], [0.0, 0.0, 0.5], [0.2, 0.4, 0.6])]  # fmt: skip
    curves = [
        Curve("map", 0, STEPS, [0.02, 0.005, 0.001], [0.0] * 3, 1.0, "zoo", 4, success[0]),
        Curve("map", 1, STEPS, [0.04, 0.010, 0.003], [0.0] * 3, 1.0, "zoo", 4, success[1]),
        Curve("sac", 0, STEPS, [0.3, 0.2, 0.1], [0.0] * 3, 1.0, "g2", 1, success[2]),
    ]
    fig = rl_report.figure(curves, "t")
    rows = np.array(fig.axes).reshape(4, 2)
    (top_four, top_one), five, (low_four, low_one), twenty = rows
    assert (
        top_four.get_title() == "t\n4-move episodes" and top_one.get_title() == "t\n1-move episodes"
    )
    assert [line.get_label() for line in top_one.get_lines() if line.get_label()[0] != "_"] == [
        "SAC (2 gradient steps / env step, 1 seed)"
    ]
    assert top_one.get_lines()[0].get_linestyle() == "--"  # the variant's style
    # the success rows (5, 10, 20 mm): the mean over seeds of the fractions, by hand
    np.testing.assert_allclose(low_four.get_lines()[0].get_ydata(), [0.0, 0.25, 0.75])
    np.testing.assert_allclose(five[0].get_lines()[0].get_ydata(), [0.0] * 3)
    np.testing.assert_allclose(twenty[1].get_lines()[0].get_ydata(), [1.0] * 3)
    assert [a.get_ylabel() for a in rows[1:, 0]] == [f"share < {t} mm" for t in (5, 10, 20)]
    np.testing.assert_allclose(low_one.get_lines()[0].get_ydata(), [0.2, 0.4, 0.6])
    assert low_four.get_ylabel() == "share < 10 mm"


def test_every_variant_is_tabulated_apart_from_rl_zoos_settings():
    """A variant's seeds never join the plain method's row, named or not."""
    assert set(rl_report.VARIANT_LABELS) == set(VARIANTS) - {"zoo"}
    curves = [Curve("sac", 0, STEPS, [0.3] * 3, [0.3] * 3, 1.0, variant, 1)
              for variant in (*VARIANTS, "new")]  # fmt: skip
    assert list(rl_report.group(curves)) == [
        "SAC (1-move episodes)",
        "SAC (2 gradient steps / env step, 1-move episodes)",
        "SAC (γ 0.5, 1-move episodes)",
        "SAC (γ 0, 1-move episodes)",
        "SAC (new, 1-move episodes)",
    ]
