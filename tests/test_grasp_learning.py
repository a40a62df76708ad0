"""The grasp-learning study: its table against the oracle, on a tiny map."""

from __future__ import annotations

import numpy as np

from envs.studies.grasp_learning import format_table, table
from learners.som.hierarchical_config import HierarchicalConfig
from models.puma560 import ARM_REACH


def test_table_rows_budgets_and_floor():
    config = HierarchicalConfig(position_lattice=(3, 2, 2), orientation_lattice=(1,))
    rows = table(seed=0, config=config, trials_per_leaf=(1.0, 20.0), test_targets=30)
    som_small, som_large, floor = rows
    assert [r.trials for r in rows] == [12, 240, 0]
    for r in rows:
        assert r.position_mm.shape == r.orientation_deg.shape == (4,)
        np.testing.assert_allclose(r.position_pct, 0.1 * r.position_mm / ARM_REACH, rtol=1e-12)
    assert floor.position_mm.max() < 1e-3 and floor.orientation_deg.max() < 1e-4
    assert som_large.position_mm[-1] < som_small.position_mm[-1]
    assert np.all(som_large.position_mm[-1] > floor.position_mm[-1])
    text = format_table(rows)
    assert text.count("\n") == 4 and "| PoseIK (floor) | - | - |" in text


def test_same_seed_same_table():
    config = HierarchicalConfig(position_lattice=(2, 2, 1), orientation_lattice=(1,))
    a, b = (table(seed=3, config=config, trials_per_leaf=(5.0,), test_targets=5) for _ in "ab")
    np.testing.assert_array_equal(a[0].position_mm, b[0].position_mm)
    np.testing.assert_array_equal(a[0].orientation_deg, b[0].orientation_deg)
