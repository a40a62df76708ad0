"""The hierarchical visuomotor map: its moves and learning step against hand-computed values,
its errors falling with training against the oracle's exact poses, determinism, checkpoints
and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from envs.studies.grasp_learning import train
from envs.studies.grasp_oracle import PoseOracle
from learners.persistence import CheckpointError
from learners.som.hierarchical import HierarchicalSOM
from learners.som.hierarchical_config import HierarchicalConfig
from models.puma560.grasp import READY
from models.puma560.kinematics import DH

SMALL = {"position_lattice": (3, 3, 2), "orientation_lattice": (2, 2, 2), "t_max": 800}
TRAINING = 800


@pytest.fixture(scope="module")
def oracle() -> PoseOracle:
    return PoseOracle()


def _map(seed: int = 0, **options) -> HierarchicalSOM:
    return HierarchicalSOM(DH.lower, DH.upper, READY, rng=seed, **{**SMALL, **options})


def _train(som: HierarchicalSOM, oracle: PoseOracle, trials: int, seed: int = 1) -> None:
    train(som, oracle, trials, np.random.default_rng(seed))


def _errors(som, oracle, poses, fine_moves=3):
    """Mean position (m) and orientation (rad) errors after the coarse and each fine move."""
    moves = []
    for u in oracle.pixels(poses):
        som.reset()
        theta = [som.act(u)]
        for _ in range(fine_moves):
            theta.append(som.act(u, oracle.hand_pixels(theta[-1])))
        moves.append(theta)
    position, orientation = oracle.errors(poses[:, None], np.array(moves))
    return position.mean(axis=0), orientation.mean(axis=0)


def _one_leaf(oracle, **options) -> HierarchicalSOM:
    """A map of one leaf sitting at READY's pixels, with A = a hand-set matrix."""
    som = HierarchicalSOM(
        DH.lower, DH.upper, READY, rng=0, position_lattice=(1,), orientation_lattice=(1,),
        **options,
    )  # fmt: skip
    f = som.features(oracle.hand_pixels(READY))
    som.w_pos[0], som.w_ori[0, 0] = f[:4], f[4:]
    som.A[0, 0] = np.arange(72.0).reshape(6, 12) * 1e-5
    return som


def test_features_are_the_first_marker_and_the_weighted_offsets():
    som = _map(orientation_gain=3.0)
    u = np.arange(12.0) ** 1.5
    expected = np.concatenate([u[:4], 3.0 * (u[4:8] - u[:4]), 3.0 * (u[8:] - u[:4])])
    np.testing.assert_allclose(som.features(u), expected, rtol=1e-15)


def test_moves_are_the_leaf_linear_map(oracle):
    """Coarse θ_rs + A (f(u) − c_rs), fine θ + A (f(u) − f(v)), computed by hand."""
    som = _one_leaf(oracle, refine=False)
    A = som.A[0, 0].copy()
    centre = som.features(oracle.hand_pixels(READY))
    u = oracle.hand_pixels(READY + 0.05)
    v = oracle.hand_pixels(READY - 0.02)
    coarse = READY + A @ (som.features(u) - centre)
    np.testing.assert_allclose(som.act(u), coarse, atol=1e-14)
    np.testing.assert_allclose(som.act(u, v), coarse + A @ som.features(u - v), atol=1e-14)
    np.testing.assert_allclose(som.act_batch(np.stack([u, u])), [coarse, coarse], atol=1e-14)


def test_refined_fine_move_takes_the_broyden_step(oracle):
    """From the second fine move on, Ā has taken (Δθ − ĀΔf)Δfᵀ/|Δf|² of the previous move."""
    som = _one_leaf(oracle)
    A = som.A[0, 0].copy()
    u, v0, v1 = (oracle.hand_pixels(READY + d) for d in (0.05, -0.02, 0.01))
    theta0 = som.act(u)
    theta1 = som.act(u, v0)
    dtheta, df = theta1 - theta0, som.features(v1 - v0)
    refined = A + np.outer(dtheta - A @ df, df) / (df @ df)
    np.testing.assert_allclose(som.act(u, v1), theta1 + refined @ som.features(u - v1), atol=1e-12)


@pytest.mark.parametrize("transport", [False, True])
def test_learning_step_with_full_rates(oracle, transport):
    """ε = ε' = 1 on one leaf: w jumps to the target's features f(u); the new A reproduces the
    trial's move exactly, A* Δf = Δθ (Widrow-Hoff); θ becomes MRS's θ* = θ_rs + A(f(u) − f(v0)),
    and with ``transport`` θ* moved along A* from the old centre c to the new one, f(u)."""
    som = _one_leaf(oracle, eps=1.0, eps_out=1.0, transport=transport)
    A = som.A[0, 0].copy()
    centre = np.concatenate([som.w_pos[0], som.w_ori[0, 0]])
    u, v0, v1 = (oracle.hand_pixels(READY + d) for d in (0.05, -0.02, 0.01))
    theta0, theta1 = READY + 0.01, READY + np.array([0.02, -0.01, 0.03, 0.05, -0.04, 0.02])
    assert som.learn(u, theta0, v0, theta1, v1)
    f = som.features(u)
    np.testing.assert_allclose(np.concatenate([som.w_pos[0], som.w_ori[0, 0]]), f, rtol=1e-15)
    df = som.features(v1 - v0)
    np.testing.assert_allclose(som.A[0, 0] @ df, theta1 - theta0, atol=1e-12)
    theta_star = READY + A @ (f - som.features(v0))
    if transport:
        theta_star += som.A[0, 0] @ (f - centre)
    np.testing.assert_allclose(som.theta[0, 0], theta_star, atol=1e-13)
    assert som.t == 1


@pytest.mark.parametrize("transport", [False, True])
def test_a_later_pair_learns_the_outputs_from_its_own_first_move(oracle, transport):
    """``coarse=False`` (fine move k -> k + 1), ε' = 1 on one leaf: θ* = θ_k + A(c − f(v_k))
    (θ_k's estimate of the joints at the centre, not the coarse rule's θ_rs + A(f(u) − f(v_k))),
    A* Δf = Δθ as for the first pair, and the input weights and t do not move."""
    som = _one_leaf(oracle, eps=1.0, eps_out=1.0, transport=transport)
    A = som.A[0, 0].copy()
    centre = np.concatenate([som.w_pos[0], som.w_ori[0, 0]])
    u, v0, v1 = (oracle.hand_pixels(READY + d) for d in (0.05, -0.02, 0.01))
    theta0, theta1 = READY + 0.01, READY + np.array([0.02, -0.01, 0.03, 0.05, -0.04, 0.02])
    assert som.learn(u, theta0, v0, theta1, v1, coarse=False)
    np.testing.assert_array_equal(np.concatenate([som.w_pos[0], som.w_ori[0, 0]]), centre)
    df = som.features(v1 - v0)
    np.testing.assert_allclose(som.A[0, 0] @ df, theta1 - theta0, atol=1e-12)
    np.testing.assert_allclose(som.theta[0, 0], theta0 + A @ (centre - som.features(v0)),
                               atol=1e-13)  # fmt: skip
    assert som.t == 0


def test_training_on_later_pairs(oracle):
    """``train(pairs=1)`` is the one-fine-move trial as before (re-implemented here, bit for
    bit); ``pairs=3`` makes three exploratory fine moves per trial and learns from each
    consecutive pair (coarse, 1), (1, 2), (2, 3), the later ones with ``coarse=False``."""
    a, b = _map(seed=3), _map(seed=3)
    _train(a, oracle, 40)
    poses, _ = oracle.targets(np.random.default_rng(1), 40)
    for u in oracle.pixels(poses):
        b.reset()
        theta0 = b.act(u)
        v0 = oracle.hand_pixels(theta0)
        theta1 = b.act(u, v0, explore=True)
        b.learn(u, theta0, v0, theta1, oracle.hand_pixels(theta1))
    for name in ("w_pos", "w_ori", "theta", "A", "df_cov"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    c, d = _map(seed=3), _map(seed=3)
    train(c, oracle, 40, np.random.default_rng(1), pairs=3)
    for u in oracle.pixels(poses):
        d.reset()
        theta = [d.act(u)]
        v = [oracle.hand_pixels(theta[0])]
        for _ in range(3):
            theta.append(d.act(u, v[-1], explore=True))
            v.append(oracle.hand_pixels(theta[-1]))
        for k in range(3):
            d.learn(u, theta[k], v[k], theta[k + 1], v[k + 1], coarse=k == 0)
    for name in ("w_pos", "w_ori", "theta", "A", "df_cov"):
        np.testing.assert_array_equal(getattr(c, name), getattr(d, name))
    assert c.t == 40 and not np.array_equal(c.A, a.A)


def test_errors_fall_with_training(oracle):
    """Against the oracle's exact poses, on targets the map never trained on."""
    poses, _ = oracle.targets(np.random.default_rng(99), 60)
    som = _map()
    position0, orientation0 = _errors(som, oracle, poses)
    _train(som, oracle, TRAINING)
    position, orientation = _errors(som, oracle, poses)
    assert position[0] < 0.5 * position0[0] and orientation[0] < 0.5 * orientation0[0]
    assert position[-1] < 0.1 * position0[-1] and orientation[-1] < 0.2 * orientation0[-1]
    assert np.all(np.diff(position) < 0) and np.all(np.diff(orientation) < 0)


def test_same_seed_same_map_other_seed_other_map(oracle):
    a, b, c = _map(seed=5), _map(seed=5), _map(seed=6)
    for som in (a, b, c):
        _train(som, oracle, 60)
    for name in ("w_pos", "w_ori", "theta", "A", "df_cov"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.w_pos, c.w_pos) and not np.array_equal(a.theta, c.theta)


def test_save_load_round_trip_continues_bit_identically(oracle, tmp_path):
    som = _map()
    _train(som, oracle, 40)
    path = som.save(tmp_path / "hsom.npz")
    loaded = HierarchicalSOM.load(path)
    assert loaded.config == som.config and loaded.t == som.t and loaded.skipped == som.skipped
    for target in (som, loaded):
        _train(target, oracle, 40, seed=3)  # uses the generator: its state was saved too
    for name in ("w_pos", "w_ori", "theta", "A", "df_cov"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(som, name))


def test_damaged_or_foreign_file_is_refused(oracle, tmp_path):
    path = _map().save(tmp_path / "hsom.npz")
    data = path.read_bytes()
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match="damaged or truncated"):
        HierarchicalSOM.load(truncated)
    flipped = bytearray(data)
    flipped[len(data) // 3] ^= 0xFF  # inside an array: the CRC no longer matches
    damaged = tmp_path / "damaged.npz"
    damaged.write_bytes(bytes(flipped))
    with pytest.raises(CheckpointError):
        HierarchicalSOM.load(damaged)
    som = _map()
    som.theta[0, 0, 0] = DH.upper[0] + 1.0  # written by hand: outside the joint ranges
    with pytest.raises(CheckpointError, match="outside the stored joint ranges"):
        HierarchicalSOM.load(som.save(tmp_path / "outside.npz"))


def test_bad_input_gives_one_line_value_errors(oracle):
    som = _map()
    u = oracle.hand_pixels(READY)
    bad_inputs = (u[:4], np.where(np.arange(12) == 5, np.nan, u), u + 1e6)
    for bad in bad_inputs:
        for call in (lambda x: som.act(x), lambda x: som.act_batch(x[None])):
            with pytest.raises(ValueError) as error:
                call(bad)
            assert "\n" not in str(error.value), str(error.value)
    som.reset()
    with pytest.raises(ValueError, match="coarse act"):
        som.act(u, u)
    theta = som.act(u)
    with pytest.raises(ValueError, match="theta0"):
        som.learn(u, theta[:3], u, theta, u)
    assert not som.learn(u, theta, np.full(12, np.nan), theta, u)
    assert som.skipped["not_visible"] == 1 and som.t == 0


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"position_lattice": (0, 3)}, "position_lattice must be 1 to 3 positive sizes"),
        ({"orientation_lattice": (2, 2, 2, 2)}, "orientation_lattice must be 1 to 3"),
        ({"eps": (1.5, 0.1)}, "learning rate in"),
        ({"orientation_gain": 0.0}, "orientation_gain must be > 0"),
        ({"refine": "yes"}, "refine must be True or False"),
        ({"backtrack": 1}, "backtrack must be True or False"),
        ({"lattice": (3, 3)}, "unknown option"),
    ],
)
def test_bad_options_are_one_line_errors(options, message):
    with pytest.raises(ValueError, match=message) as error:
        HierarchicalConfig.of(**options)
    assert "\n" not in str(error.value)


def test_config_round_trips_through_its_dictionary():
    config = HierarchicalConfig.of(position_lattice=(4, 3), eps=(0.5, 0.05), refine=False)
    assert HierarchicalConfig.from_dict(config.to_dict()) == config
    older = {k: v for k, v in config.to_dict().items() if k != "backtrack"}  # saved before it
    assert HierarchicalConfig.from_dict(older).backtrack


def _feature_jacobian(som, oracle, theta, h=1e-6):
    """∂f/∂θ (12, 6) of the hand's features by central differences."""
    columns = []
    for j in range(6):
        step = np.zeros(6)
        step[j] = h
        plus, minus = (som.features(oracle.hand_pixels(theta + s)) for s in (step, -step))
        columns.append((plus - minus) / (2 * h))
    return np.stack(columns, axis=1)


def _overshooting(oracle, gain, offset, **options):
    """A one-leaf map whose A is ``gain`` (∂f/∂θ)⁺ at READY, the target u of the hand at
    READY + ``offset`` (6,) rad, its features f and the coarse command: (som, u, f, θ0)."""
    som = _one_leaf(oracle, refine=False, **options)
    som.A[0, 0] = gain * np.linalg.pinv(_feature_jacobian(som, oracle, READY))
    u = oracle.hand_pixels(READY + np.asarray(offset))
    return som, u, som.features(u), som.act(u)


@pytest.mark.parametrize("backtrack", [False, True])
def test_backtracking_turns_overshooting_fine_moves_into_converging_ones(oracle, backtrack):
    """A = 2.6 (∂f/∂θ)⁺: every full fine step overshoots by 1.6× (the errors grow); a
    backtracked one, from the best pose with half the step, overshoots by 0.3× (they fall).
    The first releases' halving (``trust_radius=0``)."""
    offset = [0.004, -0.003, 0.002, 0.01, -0.008, 0.006]
    som, u, f, theta = _overshooting(oracle, 2.6, offset, backtrack=backtrack, trust_radius=0.0)
    errors = []
    for _ in range(10):
        fv = som.features(oracle.hand_pixels(theta))
        errors.append(np.linalg.norm(f - fv))
        theta = som.act(u, oracle.hand_pixels(theta))
    if backtrack:
        assert errors[-1] < 1e-3 * errors[0]
    else:
        assert errors[-1] > 10 * errors[0]


def test_backtracking_copy_keeps_what_the_map_learned(oracle):
    som = _map()
    _train(som, oracle, 200)
    plain = som.with_fine_moves(refine=True, backtrack=False)
    assert not plain.config.backtrack and som.config.backtrack
    for name in ("w_pos", "w_ori", "theta", "A", "df_cov"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(som, name))
    assert plain.t == som.t and plain.rng.random() == som.rng.random()


def test_published_fine_moves_are_the_plain_formula(oracle):
    """``refine=False, backtrack=False``: every fine move is θ_{k+1} = θ_k + A_rs (f(u) − f(v_k))
    of the target's winning leaf, clipped into the joint ranges, whatever ``trust_radius``."""
    trained = _map()
    _train(trained, oracle, 200)
    poses, _ = oracle.targets(np.random.default_rng(7), 5)
    for trust_radius in (0.0, 0.2, 1e-3):
        som = trained.with_fine_moves(refine=False, backtrack=False, trust_radius=trust_radius)
        for u in oracle.pixels(poses):
            f = som.features(u)
            r, s = (int(i[0]) for i in som.winners(f[None]))
            expected = np.clip(
                som.theta[r, s] + som.A[r, s] @ (f - som.centre(np.array([r]), np.array([s]))[0]),
                DH.lower, DH.upper,
            )  # fmt: skip
            som.reset()
            theta = som.act(u)
            np.testing.assert_allclose(theta, expected, atol=1e-12)
            for _ in range(5):
                v = oracle.hand_pixels(theta)
                expected = np.clip(theta + som.A[r, s] @ (f - som.features(v)), DH.lower, DH.upper)
                theta = som.act(u, v)
                np.testing.assert_allclose(theta, expected, atol=1e-12)


def test_trust_region_caps_grows_and_shrinks_the_fine_steps(oracle):
    """A = 4 (∂f/∂θ)⁺: the first fine step is Ā e scaled to a largest joint change of ρ0; the
    radius doubles after a move that beat the best and halves after an undone one."""
    rho = 0.01
    som, u, f, theta = _overshooting(
        oracle, 4.0, [0.05, -0.04, 0.03, 0.1, -0.08, 0.06], trust_radius=rho
    )
    radii = []
    for _ in range(6):
        v = oracle.hand_pixels(theta)
        before = som._step
        new = som.act(u, v)
        base = som._cmd_before  # the pose this move started from (θ_k or the best)
        step = new - base
        full = som.A[0, 0] @ (f - som.features(oracle.hand_pixels(base)))
        assert np.abs(step).max() <= som._step * (1 + 1e-12)
        if np.abs(full).max() > som._step:  # capped: Ā e's direction, the radius's length
            np.testing.assert_allclose(step, full * som._step / np.abs(full).max(), atol=1e-12)
        assert som._step == 2 * before or som._step <= before
        radii.append(som._step)
        theta = new
    assert radii[0] == rho and max(radii) > rho


def _singular_objects(oracle, n=12):
    """n object poses (n, 4, 4) whose exact joints (n, 6), from ``pose_ik`` in ready's branch,
    have θ5 within 0.5-4° of the wrist singularity."""
    from models.puma560 import BASE_POS
    from models.puma560.inverse import pose_ik

    rng = np.random.default_rng(5)
    poses, exact = [], []
    for _ in range(n):
        theta = READY + rng.uniform(-0.3, 0.3, 6)
        theta[4] = -np.radians(rng.uniform(0.5, 4.0))
        pose = oracle.hand_pose(theta)
        T06 = pose.copy()
        T06[:3, 3] -= BASE_POS
        joints, valid = pose_ik(T06, 1, 1, -1, reference=READY)
        assert valid and abs(np.degrees(joints[4])) < 4.0
        poses.append(pose)
        exact.append(joints)
    return np.array(poses), np.array(exact)


def test_trust_region_fine_moves_converge_at_the_wrist_singularity(oracle):
    """Objects with θ5 within 4° of 0; for each a one-leaf map whose leaf sits 20° and −17° off
    the exact θ4 and θ6 with the exact local inverse there, A = (∂f/∂θ)⁺. After five fine moves
    the trust region grasps at least 9 of 12 to 0.2 mm and 0.2° with the wrist unflipped (θ5 of
    the exact joints' sign, θ4 within 90°) and none wanders off; the halving backtracking grasps
    fewer and sends some to a joint limit half a metre away."""
    poses, exact = _singular_objects(oracle)
    offset = np.array([0.01, -0.01, 0.01, 0.35, 0.04, -0.3])
    results = {}
    for trust_radius in (0.0, 0.2):
        good, worst = 0, 0.0
        for pose, joints in zip(poses, exact, strict=True):
            som = _one_leaf(oracle, trust_radius=trust_radius)
            start = joints + offset
            f0 = som.features(oracle.hand_pixels(start))
            som.w_pos[0], som.w_ori[0, 0], som.theta[0, 0] = f0[:4], f0[4:], start
            som.A[0, 0] = np.linalg.pinv(_feature_jacobian(som, oracle, start))
            u = oracle.pixels(pose)
            theta = som.act(u)
            for _ in range(5):
                theta = som.act(u, oracle.hand_pixels(theta))
            position, orientation = oracle.errors(pose, theta)
            unflipped = np.sign(theta[4]) == np.sign(joints[4]) and abs(theta[3] - joints[3]) < 1.6
            good += bool(position < 2e-4 and orientation < np.radians(0.2) and unflipped)
            worst = max(worst, float(position))
        results[trust_radius] = good, worst
    assert results[0.2][0] >= 9 and results[0.2][1] < 0.2
    assert results[0.0][0] < results[0.2][0] and results[0.0][1] > 0.5
