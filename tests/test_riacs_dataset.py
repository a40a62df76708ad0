"""The RIACS data set: every row satisfies the report's camera and arm formulas (recomputed here),
the grid has the MATLAB loop counts, and the seeded splits behave as documented."""

import numpy as np
import pytest

from envs.cli import riacs_dataset
from learners.persistence import load_npz
from models.analyses import riacs_dataset as D

from helpers import assert_drawn_png


@pytest.fixture(scope="module")
def data():
    return D.build3dpts(0.6, 0.4, np.pi / 60)


def test_loop_counts_of_three_degree_steps(data):
    # θ1: .001 + 29·3° = 87.1° ≤ 90°; θ2: up to 90° - asin(2/3) = 48.19°: .001 + 16·3° = 48.06°;
    # θ3: up to 179°: .001 + 59·3° = 177.06°. So 30 · 17 · 60 rows.
    assert [len(r) for r in D.joint_ranges(0.6, 0.4, np.pi / 60)] == [30, 17, 60]
    assert data.shape == (30 * 17 * 60, 10)
    # The MATLAB nesting: θ1 outermost, θ3 innermost.
    np.testing.assert_allclose(
        data[:3, 7:],
        [[0.001] * 3, [0.001, 0.001, 0.001 + np.pi / 60], [0.001, 0.001, 0.001 + 2 * np.pi / 60]],
    )


def test_rows_satisfy_the_arm_and_camera_formulas(data):
    x, y, z, x1, y1, x2, y2, t1, t2, t3 = data.T
    # robot3df, from the link geometry: link 1 at elevation θ2, link 2 folded back by θ3.
    rho = 0.6 * np.cos(t2) - 0.4 * np.cos(t2 + t3)
    np.testing.assert_allclose(x, rho * np.sin(t1), atol=1e-12)
    np.testing.assert_allclose(y, rho * np.cos(t1), atol=1e-12)
    np.testing.assert_allclose(z, 0.6 * np.sin(t2) - 0.4 * np.sin(t2 + t3), atol=1e-12)
    # camera(f = 1, d = 0.3): pinholes at (±0.3, 0, 1) looking down.
    np.testing.assert_allclose(x1, (x - 0.3) / (1 - z), atol=1e-12)
    np.testing.assert_allclose(x2, (x + 0.3) / (1 - z), atol=1e-12)
    np.testing.assert_allclose(y1, y / (1 - z), atol=1e-12)
    np.testing.assert_allclose(y2, y / (1 - z), atol=1e-12)
    # Every point lies in the report's unit cube corner (x, y ≥ 0) and reach.
    assert np.all(x >= 0) and np.all(y >= 0) and np.all(np.hypot(np.hypot(x, y), z) <= 1.0)


def test_buildtset_samples_rows_with_replacement_reproducibly(data):
    a = D.buildtset(data, 5000, np.random.default_rng(3))
    b = D.buildtset(data, 5000, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)
    rows = {tuple(r) for r in data}
    assert all(tuple(r) in rows for r in a)
    assert len({tuple(r) for r in a}) < 5000  # 5000 draws from 30600 repeat (birthday bound)


def test_split_without_replacement_is_disjoint(data):
    train, test = D.train_test_split(data, 2000, 1000, np.random.default_rng(4), replace=False)
    assert len({tuple(r) for r in train}) == 2000
    assert not {tuple(r) for r in train} & {tuple(r) for r in test}
    with pytest.raises(ValueError, match="exceeds"):
        D.train_test_split(data, len(data), 1, np.random.default_rng(4), replace=False)


def test_bad_step_raises():
    with pytest.raises(ValueError, match="stepsize"):
        D.build3dpts(0.6, 0.4, 0.0)


def test_script_writes_npz_csv_and_plots(tmp_path):
    riacs_dataset.main(
        ["--out", str(tmp_path), "--stepsize", "0.3", "--train", "50", "--test", "20"]
    )
    config, arrays = load_npz(tmp_path / "riacs_dataset.npz", "riacs-dataset", 1)
    assert config["columns"] == list(D.COLUMNS)
    assert arrays["train"].shape == (50, 10) and arrays["test"].shape == (20, 10)
    csv = np.loadtxt(tmp_path / "data.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(csv, arrays["data"], rtol=1e-9, atol=1e-12)
    header = (tmp_path / "train.csv").read_text().splitlines()[0]
    assert header == "x,y,z,x1,y1,x2,y2,theta1,theta2,theta3"
    assert_drawn_png(tmp_path / "axis_projections.png")
