"""VisuomotorSOM: hand-computed moves and updates, the printed Brause equations, determinism,
checkpoints, bad input, and learning to reach on the simulated RIACS arm."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from learners.persistence import CheckpointError, save_npz
from learners.som.controller import VisuomotorSOM
from learners.som.lattice import H_CUTOFF
from learners.som.schedules import Schedule
from models import riacs

from helpers import SMALL_COORDS as COORDS
from helpers import hand_set_map, riacs_pixels

LOW, HIGH = np.array([-1.0, -2.0]), np.array([1.0, 2.0])  # J = 2 joints of the small maps


def small_map(**kw) -> VisuomotorSOM:
    """Lattice (3, 2), 2-D input, 2 joints, with hand-set arrays: w_r at the lattice point.
    Fine moves with MRS's averaged Ā unless ``abar`` says otherwise (the hand computations)."""
    kw.setdefault("abar", "average")
    return hand_set_map(LOW, HIGH, **kw)


def gauss(s: int, sigma: float) -> np.ndarray:
    """exp(−|r − s|² / 2σ²) over the small lattice, by explicit loop."""
    return np.array(
        [
            math.exp(-((r[0] - COORDS[s][0]) ** 2 + (r[1] - COORDS[s][1]) ** 2) / (2 * sigma**2))
            for r in COORDS
        ]
    )


# ------------------------------------------------------------------------------------ moves
def test_winner_only_act_is_theta_plus_linear_term_by_hand():
    som = small_map(averaging="winner")
    theta, A = np.zeros((6, 2)), np.zeros((6, 2, 2))
    theta[2], A[2] = [0.1, 0.2], [[1.0, 0.0], [0.0, 2.0]]
    som.theta, som.A = theta, A
    # u = (1.2, 0.1): nearest w is (1, 0), neuron 2; θ0 = (0.1 + 0.2, 0.2 + 2·0.1)
    np.testing.assert_allclose(som.act([1.2, 0.1]), [0.3, 0.4], rtol=0, atol=1e-15)
    # fine move from v = (1.0, 0.0): θ1 = θ0 + A_2 (u − v) = (0.3 + 0.2, 0.4 + 0.2)
    np.testing.assert_allclose(som.act([1.2, 0.1], [1.0, 0.0]), [0.5, 0.6], atol=1e-15)


def test_neighbourhood_act_and_fine_moves_match_a_loop_over_neurons():
    sigma = 0.9
    som = small_map(sigma_out=sigma)
    u, v0, v1 = np.array([1.2, 0.1]), np.array([1.0, 0.3]), np.array([1.15, 0.12])
    g = gauss(2, sigma)  # winner: neuron 2 at (1, 0)
    local = [som.theta[r] + som.A[r] @ (u - som.w[r]) for r in range(6)]
    theta0 = sum(g[r] * local[r] for r in range(6)) / g.sum()
    abar = sum(g[r] * som.A[r] for r in range(6)) / g.sum()
    np.testing.assert_allclose(som.act(u), theta0, rtol=1e-13)
    theta1 = theta0 + abar @ (u - v0)
    np.testing.assert_allclose(som.act(u, v0), theta1, rtol=1e-13)
    # second fine move: Ā first takes the Broyden step of the first fine move
    d_theta, dv = theta1 - theta0, v1 - v0
    refined = abar + np.outer(d_theta - abar @ dv, dv) / (dv @ dv)
    np.testing.assert_allclose(refined @ dv, d_theta, rtol=1e-12)  # the secant condition
    np.testing.assert_allclose(som.act(u, v1), theta1 + refined @ (u - v1), rtol=1e-13)
    fixed = small_map(sigma_out=sigma, refine=False)
    fixed.act(u), fixed.act(u, v0)
    np.testing.assert_allclose(fixed.act(u, v1), theta1 + abar @ (u - v1), rtol=1e-13)


def test_commands_are_clipped_into_the_joint_ranges():
    som = small_map(averaging="winner")
    som.theta = np.tile([5.0, -5.0], (6, 1))
    som.A = np.zeros((6, 2, 2))
    np.testing.assert_array_equal(som.act([0.2, 0.9]), [1.0, -2.0])
    np.testing.assert_array_equal(som.act_batch(np.array([[0.2, 0.9], [2, 1]])), [[1, -2]] * 2)
    som.A = np.tile(np.eye(2) * 100.0, (6, 1, 1))
    np.testing.assert_array_equal(som.act([0.2, 0.9]), [1.0, -2.0])  # (25, -15) clipped
    np.testing.assert_array_equal(som.act([0.2, 0.9], [10.0, -10.0]), [-1.0, 2.0])


@pytest.mark.parametrize("t", [0, 2500, 10_000])  # σ' = 2.5 (whole map), 0.63, 0.01 (winner)
def test_act_batch_equals_act_row_by_row(t):
    som = VisuomotorSOM(riacs.LOWER, riacs.UPPER, rng=3, input_high=[320, 240, 320, 240])
    som.t = t
    U = np.random.default_rng(4).uniform(0, 240, size=(50, 4))
    rows = np.array([som.act(u) for u in U])
    np.testing.assert_allclose(som.act_batch(U), rows, rtol=1e-12, atol=1e-12)


def test_exploration_adds_the_generators_normal_noise():
    som = small_map(averaging="winner", explore=0.1)
    u, v = np.array([1.2, 0.1]), np.array([1.0, 0.0])
    theta0 = som.act(u)
    twin = np.random.Generator(type(som.rng.bit_generator)())
    twin.bit_generator.state = som.rng.bit_generator.state
    expected = np.clip(theta0 + som.A[2] @ (u - v) + twin.normal(0.0, 0.1, 2), LOW, HIGH)
    np.testing.assert_array_equal(som.act(u, v, explore=True), expected)


# ------------------------------------------------------------------------------------ learning
TRIAL = {
    "u": np.array([1.2, 0.1]),
    "theta0": np.array([0.3, -0.4]),
    "v0": np.array([1.0, 0.3]),
    "theta1": np.array([0.35, -0.3]),
    "v1": np.array([1.1, 0.2]),
}


@pytest.mark.parametrize("target", ["coarse-error", "fine-error"])
def test_one_learn_equals_the_update_by_hand(target):
    eps, sigma, eps_out, sigma_out = 0.5, 0.8, 0.3, 0.6
    som = small_map(theta_target=target, eps=eps, sigma=sigma, eps_out=eps_out, sigma_out=sigma_out)
    w, th, A = som.w.copy(), som.theta.copy(), som.A.copy()
    u, th0, v0, th1, v1 = TRIAL.values()
    s = int(np.argmin([np.hypot(*(u - w[r])) for r in range(6)]))
    d_theta, dv = th1 - th0, v1 - v0
    a_star = A[s] + np.outer(d_theta - A[s] @ dv, dv) / (dv @ dv)
    theta_star = th[s] + A[s] @ (u - v0) if target == "coarse-error" else th1 + A[s] @ (w[s] - v1)
    h, h_out = gauss(s, sigma), gauss(s, sigma_out)
    assert h.min() > H_CUTOFF and h_out.min() > H_CUTOFF  # nothing truncated here
    assert som.learn(**TRIAL) is True
    for r in range(6):
        np.testing.assert_allclose(som.w[r], w[r] + eps * h[r] * (u - w[r]), rtol=1e-13)
        expected = np.clip(th[r] + eps_out * h_out[r] * (theta_star - th[r]), LOW, HIGH)
        np.testing.assert_allclose(som.theta[r], expected, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(som.A[r], A[r] + eps_out * h_out[r] * (a_star - A[r]), 1e-13)
    assert som.t == 1


def test_the_fine_error_target_reproduces_the_printed_equations_for_brause_protocol():
    """Brause (3.9), (3.10): coarse move Θ_c, fine move Θ_c + A_c(x − w_c)."""
    eps_out = 0.7
    som = small_map(theta_target="fine-error", averaging="winner", eps_out=eps_out, sigma_out=0.01)
    x, x_i, x_f = np.array([1.2, 0.1]), np.array([1.05, 0.02]), np.array([1.18, 0.13])
    c = 2
    theta_c, a_c, w_c = som.theta[c].copy(), som.A[c].copy(), som.w[c].copy()
    som.learn(x, theta_c, x_i, theta_c + a_c @ (x - w_c), x_f)
    theta_star = theta_c + a_c @ (x - x_f)  # (3.9)
    d = x_f - x_i
    a_star = a_c + np.outer(a_c @ ((x - x_f) - (w_c - x_i)), d) / (d @ d)  # (3.10)
    np.testing.assert_allclose(som.theta[c], theta_c + eps_out * (theta_star - theta_c), 1e-13)
    np.testing.assert_allclose(som.A[c], a_c + eps_out * (a_star - a_c), rtol=1e-13)


def test_widrow_hoff_step_makes_the_winner_map_the_sensed_move_exactly():
    som = small_map(averaging="winner", eps_out=1.0, sigma_out=0.01)
    som.learn(**TRIAL)
    np.testing.assert_allclose(
        som.A[2] @ (TRIAL["v1"] - TRIAL["v0"]), TRIAL["theta1"] - TRIAL["theta0"], rtol=1e-13
    )


@pytest.mark.parametrize("t", [0, 1500, 3500, 9000])  # whole map, truncated, winner only
def test_learn_on_the_default_lattice_matches_the_full_gaussian_update(t):
    som = VisuomotorSOM(riacs.LOWER, riacs.UPPER, rng=5, input_high=[320, 240, 320, 240])
    som.t = t
    eps, sigma, eps_out, sigma_out, _ = som.params()
    w, th, A = som.w.copy(), som.theta.copy(), som.A.copy()
    u = w[100] + 0.3
    s = int(np.argmin(((w - u) ** 2).sum(1)))
    d2 = ((som.coords - som.coords[s]) ** 2).sum(1)
    v0, v1 = u + np.array([2.0, -1.0, 1.0, -1.0]), u + np.array([0.5, 0.2, -0.3, 0.2])
    th0, th1 = th[s] + 0.01, th[s] + [0.03, -0.02, 0.01]
    som.learn(u, th0, v0, th1, v1)
    step = eps * np.exp(-d2 / (2 * sigma**2))  # every neuron, none truncated
    bound = H_CUTOFF * eps * np.abs(u - w).max()  # what truncation may leave out
    np.testing.assert_allclose(som.w, w + step[:, None] * (u - w), rtol=1e-14, atol=bound)
    dv = v1 - v0
    a_star = A[s] + np.outer(th1 - th0 - A[s] @ dv, dv) / (dv @ dv)
    step = eps_out * np.exp(-d2 / (2 * sigma_out**2))
    bound = H_CUTOFF * eps_out * np.abs(a_star - A).max()
    np.testing.assert_allclose(som.A, A + step[:, None, None] * (a_star - A), 1e-14, bound)
    assert np.abs(som.A - A).max() > 1e3 * bound  # the update itself is far above that


# ------------------------------------------------------------------------------------ input
BAD_CALLS = {
    "act u NaN": lambda m: m.act([np.nan, 0.0]),
    "act u shape": lambda m: m.act([0.0, 0.0, 0.0]),
    "act v inf": lambda m: (m.act([1.0, 0.0]), m.act([1.0, 0.0], [np.inf, 0.0])),
    "fine move first": lambda m: m.act([1.0, 0.0], [1.0, 0.0]),
    "learn u NaN": lambda m: m.learn(**{**TRIAL, "u": np.array([np.nan, 0.0])}),
    "learn theta0 shape": lambda m: m.learn(**{**TRIAL, "theta0": np.zeros(3)}),
    "learn theta1 inf": lambda m: m.learn(**{**TRIAL, "theta1": np.array([np.inf, 0.0])}),
    "learn v0 shape": lambda m: m.learn(**{**TRIAL, "v0": np.zeros((2, 1))}),
    "act_batch NaN": lambda m: m.act_batch(np.array([[0.0, np.nan]])),
}


@pytest.mark.parametrize("call", BAD_CALLS.values(), ids=BAD_CALLS.keys())
def test_bad_input_raises_and_leaves_the_map_unchanged(call):
    som = small_map()
    before = (som.w.copy(), som.theta.copy(), som.A.copy(), som.t)
    with pytest.raises(ValueError, match=r"shape|NaN|inf|coarse"):
        call(som)
    np.testing.assert_array_equal(som.w, before[0])
    np.testing.assert_array_equal(som.theta, before[1])
    np.testing.assert_array_equal(som.A, before[2])
    assert som.t == before[3]


def test_invisible_markers_and_tiny_moves_are_skipped_and_counted():
    som = small_map(min_dv=0.01)
    before = (som.w.copy(), som.theta.copy(), som.A.copy())
    assert not som.learn(**{**TRIAL, "v1": np.array([np.nan, np.nan])})
    assert not som.learn(**{**TRIAL, "v1": TRIAL["v0"] + 0.005})
    assert som.skipped == {"not_visible": 1, "small_dv": 1} and som.t == 0
    for a, b in zip((som.w, som.theta, som.A), before, strict=True):
        np.testing.assert_array_equal(a, b)


def test_bad_options_name_the_valid_choices():
    with pytest.raises(ValueError, match="coarse-error, fine-error"):
        small_map(theta_target="kohonen")
    with pytest.raises(ValueError, match="unknown rule 'kohonen'; valid: mrs, brause"):
        small_map(rule="kohonen")  # the old name, values as files store them
    with pytest.raises(ValueError, match="neighbourhood, winner"):
        small_map(averaging="all")
    with pytest.raises(ValueError, match=r"theta_init must have shape \(2,\)"):
        small_map(theta_init=[0.0])
    with pytest.raises(ValueError, match="lower < upper"):
        VisuomotorSOM([1.0], [0.0])
    with pytest.raises(ValueError, match=r"w must have the map's shape \(6, 2\)"):
        small_map().w = np.zeros((5, 2))
    with pytest.raises(ValueError, match="A contains NaN or inf"):
        small_map().A = np.full((6, 2, 2), np.nan)


def test_schedule_is_geometric_and_holds_its_final_value():
    s = Schedule(2.0, 0.02)
    assert s(0, 100) == 2.0 and s(100, 100) == pytest.approx(0.02, rel=1e-15)
    assert s(50, 100) == pytest.approx(math.sqrt(2.0 * 0.02), rel=1e-15)
    assert s(300, 100) == s(100, 100)
    assert Schedule(0.0, 0.0)(7, 10) == 0.0
    with pytest.raises(ValueError, match="initial > 0 and final > 0"):
        Schedule(1.0, 0.0)


# ------------------------------------------------------------------------------------ seeds, files
def test_same_seed_same_map_other_seed_other_map():
    a, b, c = (VisuomotorSOM(riacs.LOWER, riacs.UPPER, rng=seed) for seed in (7, 7, 8))
    g = VisuomotorSOM(riacs.LOWER, riacs.UPPER, rng=np.random.default_rng(7))
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        np.testing.assert_array_equal(getattr(a, name), getattr(g, name))
    assert not np.array_equal(a.w, c.w) and not np.array_equal(a.A, c.A)


pixels = riacs_pixels


def train(som: VisuomotorSOM, targets: np.ndarray, start: int = 0) -> None:
    """One trial per target; trial number start + k is not seen when it is a multiple of 37."""
    for k, target in enumerate(targets, start):
        u = pixels(target)
        som.reset()
        theta0 = som.act(u)
        v0 = pixels(theta0)
        theta1 = som.act(u, v0, explore=True)
        v1 = pixels(theta1) if k % 37 else np.full(4, np.nan)  # now and then not seen
        som.learn(u, theta0, v0, theta1, v1)


def riacs_targets(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(riacs.LOWER + 0.1, riacs.UPPER - 0.1, (n, 3))


def new_map(t_max: int = 300) -> VisuomotorSOM:
    return VisuomotorSOM(riacs.LOWER, riacs.UPPER, t_max=t_max, rng=11, input_high=[320] * 4)


def test_save_load_round_trip_is_exact(tmp_path):
    som = new_map()
    train(som, riacs_targets(60, 1))
    u = pixels(riacs_targets(1, 2)[0])
    som.act(u)  # mid-trial: the fine-move memory is saved too
    som.save(tmp_path / "som.npz")
    back = VisuomotorSOM.load(tmp_path / "som.npz")
    for name in ("w", "theta", "A", "lower", "upper", "input_low", "input_high"):
        np.testing.assert_array_equal(getattr(back, name), getattr(som, name))
    assert back.rng.bit_generator.state == som.rng.bit_generator.state
    assert (back.t, back.skipped, back.theta_target, back.lattice) == (
        som.t,
        som.skipped,
        som.theta_target,
        som.lattice,
    )
    assert back.skipped["not_visible"] == 2
    for theta in ([0.5, 0.4, 1.0], [0.6, 0.3, 1.2]):  # fine moves from the saved memory
        v = pixels(np.array(theta))
        np.testing.assert_array_equal(back.act(u, v, explore=True), som.act(u, v, explore=True))


def test_train_save_load_continue_is_bit_identical(tmp_path):
    targets = riacs_targets(300, 3)
    whole = new_map()
    train(whole, targets)
    first = new_map()
    train(first, targets[:120])
    first.save(tmp_path / "ck.npz")
    second = VisuomotorSOM.load(tmp_path / "ck.npz")
    train(second, targets[120:], start=120)
    for name in ("w", "theta", "A"):
        np.testing.assert_array_equal(getattr(second, name), getattr(whole, name))
    assert second.rng.bit_generator.state == whole.rng.bit_generator.state
    assert (second.t, second.skipped) == (whole.t, whole.skipped)


def test_missing_damaged_truncated_or_foreign_files_raise_checkpoint_error(tmp_path):
    with pytest.raises(CheckpointError, match="no such file"):
        VisuomotorSOM.load(tmp_path / "absent.npz")
    good = small_map().save(tmp_path / "good.npz")
    data = good.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match="damaged or truncated"):
        VisuomotorSOM.load(tmp_path / "cut.npz")
    flipped = bytearray(data)
    at = data.index(b"theta.npy") + 200  # inside the stored array
    flipped[at : at + 8] = b"\xff" * 8
    (tmp_path / "flipped.npz").write_bytes(bytes(flipped))
    with pytest.raises(CheckpointError, match="damaged or truncated"):
        VisuomotorSOM.load(tmp_path / "flipped.npz")
    save_npz(tmp_path / "other.npz", "NATEnet", 1, {}, {"x": np.zeros(2)})
    with pytest.raises(CheckpointError, match="holds a 'NATEnet', not a 'VisuomotorSOM'"):
        VisuomotorSOM.load(tmp_path / "other.npz")
    np.savez(tmp_path / "plain.npz", w=np.zeros(3))
    with pytest.raises(CheckpointError, match="not a visuomotor checkpoint"):
        VisuomotorSOM.load(tmp_path / "plain.npz")
    save_npz(tmp_path / "v9.npz", "VisuomotorSOM", 9, {}, {})
    with pytest.raises(CheckpointError, match="format version 9"):
        VisuomotorSOM.load(tmp_path / "v9.npz")
    with np.load(good) as stored:
        config = json.loads(str(stored["__config__"]))
        arrays = {k: stored[k] for k in stored.files if not k.startswith("__")}
    save_npz(tmp_path / "bad_w.npz", "VisuomotorSOM", 1, config, {**arrays, "w": np.zeros(3)})
    with pytest.raises(CheckpointError, match="array 'w'"):
        VisuomotorSOM.load(tmp_path / "bad_w.npz")
    del arrays["A"]
    save_npz(tmp_path / "no_a.npz", "VisuomotorSOM", 1, config, arrays)
    with pytest.raises(CheckpointError, match="incomplete or inconsistent"):
        VisuomotorSOM.load(tmp_path / "no_a.npz")


# ------------------------------------------------------------------------------------ learning
#: 2000 trials (t_max = 2000), seed 0, 300 held-out targets; measured mean errors in % of the
#: 1 m reach after coarse, 1 and 2 fine moves: 8.3, 5.1, 3.0 after 500 trials and 5.7, 3.2, 1.6
#: after 2000 (10 000 trials reach 1.55, 0.43, 0.08).
COARSE_LIMIT_PCT, FINE2_LIMIT_PCT = 7.5, 2.5


@pytest.fixture(scope="module")
def riacs_rig():
    import mujoco

    import models
    from envs import StereoRig

    model = models.load_model("riacs")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return StereoRig(model, data)


def test_learning_to_reach_riacs_from_projected_pixels(riacs_rig):
    rig, reach = riacs_rig, riacs.ARM_REACH

    def tcp(theta):
        return np.array(riacs.robot3df(riacs.LINK1, riacs.LINK2, *theta))

    def sense(theta):
        return rig.project(tcp(theta)[None])[0]

    rng = np.random.default_rng(0)
    train_points = riacs.WORKSPACE.sample(rng, 2000)
    test_points = riacs.WORKSPACE.sample(np.random.default_rng(1000), 300)
    U, U_test = rig.project(train_points), rig.project(test_points)
    image = [rig.width, rig.height, rig.width, rig.height]
    som = VisuomotorSOM(riacs.LOWER, riacs.UPPER, t_max=2000, rng=0, input_high=image)

    def errors_pct() -> np.ndarray:  # mean distance after coarse, 1 and 2 fine moves
        out = np.zeros((3, len(U_test)))
        for i, (u, p) in enumerate(zip(U_test, test_points, strict=True)):
            som.reset()
            theta = som.act(u)
            for k in range(3):
                out[k, i] = np.linalg.norm(tcp(theta) - p)
                if k < 2:
                    theta = som.act(u, sense(theta))
        return out.mean(1) / reach * 100

    curve = []
    for start, stop in ((0, 500), (500, 2000)):
        for u in U[start:stop]:
            som.reset()
            theta0 = som.act(u)
            v0 = sense(theta0)
            theta1 = som.act(u, v0, explore=True)
            som.learn(u, theta0, v0, theta1, sense(theta1))
        curve.append(errors_pct())
    early, final = curve
    print("RIACS errors % of reach after 500, 2000 trials:", early.round(3), final.round(3))
    assert final[0] < COARSE_LIMIT_PCT and final[2] < FINE2_LIMIT_PCT, final
    assert np.all(final < 0.85 * early), (early, final)  # falls along training
    assert final[1] < 0.7 * final[0] and final[2] < 0.7 * final[1]  # every fine move helps
    assert som.skipped == {"not_visible": 0, "small_dv": 0} and som.t == 2000
