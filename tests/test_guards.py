"""Finite but absurd values are refused before anything changes: learner inputs far outside the
input box, constructor numbers, and damaged or hand-edited checkpoint files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from learners.natenet import NATEnet
from learners.persistence import CheckpointError
from learners.som.controller import VisuomotorSOM

LOW, HIGH = np.array([-1.0, -2.0]), np.array([1.0, 2.0])  # joint ranges, rad
BOX = (np.zeros(2), np.array([320.0, 240.0]))  # input box, px
U, TH = np.array([100.0, 80.0]), np.array([0.1, 0.2])
TRIAL = {"u": U, "theta0": TH, "v0": U + 5.0, "theta1": TH + 0.1, "v1": U + 9.0}


def som() -> VisuomotorSOM:
    return VisuomotorSOM(LOW, HIGH, lattice=(3, 2), input_dim=2, rng=0, input_low=BOX[0],
                         input_high=BOX[1])  # fmt: skip


def _state(m: VisuomotorSOM):
    return (m.w.copy(), m.theta.copy(), m.A.copy(), m.t, dict(m.skipped),
            m.rng.bit_generator.state)  # fmt: skip


def _same(a, b) -> None:
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y) if isinstance(x, np.ndarray) else None
        assert isinstance(x, np.ndarray) or x == y


FAR = {
    "learn u": lambda m: m.learn(**{**TRIAL, "u": np.array([1e200, 0.0])}),
    "learn v1": lambda m: m.learn(**{**TRIAL, "v1": np.array([0.0, 1e7])}),
    "learn theta0": lambda m: m.learn(**{**TRIAL, "theta0": np.array([0.0, 1e5])}),
    "act u": lambda m: m.act(np.array([-1e6, 0.0])),
    "act v": lambda m: (m.act(U), m.act(U, np.array([4000.0, 0.0]))),
    "act_batch": lambda m: m.act_batch(np.array([U, [0.0, 1e9]])),
}


@pytest.mark.parametrize("call", FAR.values(), ids=FAR.keys())
def test_som_inputs_far_outside_the_box_are_refused_and_the_map_is_unchanged(call):
    m = som()
    before = _state(m)
    with pytest.raises(ValueError, match="more than 10 box sizes outside the"):
        call(m)
    _same(_state(m), before)
    assert m.learn(**TRIAL)  # 10 image sizes away is still accepted: only the absurd is refused
    m.act(np.array([3000.0, -2000.0]))


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"theta_init": [np.nan, 0.0]}, "theta_init"),
        ({"joint_upper": [np.inf, 2.0]}, "joint_upper"),
        ({"eps": np.inf}, "eps"),
        ({"eps_out": (0.5, 3.0)}, "eps_out is a learning rate"),
        ({"input_high": [np.inf, 1.0]}, "input_high"),
        ({"min_dv": np.nan}, "min_dv"),
    ],
)
def test_som_constructor_refuses_non_finite_or_absurd_numbers(kwargs, named):
    args = {"joint_lower": LOW, "joint_upper": HIGH, "lattice": (3, 2), "input_dim": 2, **kwargs}
    with pytest.raises(ValueError, match=named):
        VisuomotorSOM(**args)


def _rewrite(path, tmp_path, name: str, edit) -> object:
    """A copy of the checkpoint at ``path`` with ``edit(contents)`` applied (a hand edit)."""
    with np.load(path) as z:
        contents = {k: z[k] for k in z.files}
    edit(contents)
    out = tmp_path / name
    np.savez(out, **contents)
    return out


def _config(edit):
    def apply(contents):
        config = json.loads(str(contents["__config__"]))
        edit(config)
        contents["__config__"] = np.array(json.dumps(config))

    return apply


DAMAGE = {
    "wrecked w": lambda c: c.__setitem__("w", np.full_like(c["w"], 1e200)),
    "NaN A": lambda c: c.__setitem__("A", np.full_like(c["A"], np.nan)),
    "theta past the joint ranges": lambda c: c.__setitem__("theta", c["theta"] + 50.0),
    "int w": lambda c: c.__setitem__("w", c["w"].astype(int)),
    "broken JSON": lambda c: c.__setitem__("__config__", np.array('{"lattice": [3, 2')),
    "JSON list": lambda c: c.__setitem__("__config__", np.array("[1, 2]")),
    "lattice as text": _config(lambda k: k.__setitem__("lattice", "3,2")),
    "refine as text": _config(lambda k: k.__setitem__("refine", "yes")),
    "unknown abar": _config(lambda k: k.__setitem__("abar", "nearest")),
    "abar as list": _config(lambda k: k.__setitem__("abar", ["local-fit"])),
    "negative t": _config(lambda k: k.__setitem__("t", -4)),
    "foreign generator": _config(lambda k: k["rng_state"].__setitem__("bit_generator", "seed")),
    "empty lattice": _config(lambda k: k.__setitem__("lattice", [])),
    "memory shape": lambda c: c.__setitem__("_cmd", np.zeros(5)),
    "version text": lambda c: c.__setitem__("__format_version__", np.array("one")),
}


@pytest.mark.parametrize("edit", DAMAGE.values(), ids=DAMAGE.keys())
def test_som_load_raises_checkpoint_error_for_every_damage(tmp_path, edit):
    m = som()
    m.learn(**TRIAL)
    m.act(U)  # leaves fine-move memory in the file
    path = m.save(tmp_path / "good.npz")
    bad = _rewrite(path, tmp_path, "bad.npz", edit)
    before = bad.read_bytes()
    with pytest.raises(CheckpointError, match=r"bad\.npz"):
        VisuomotorSOM.load(bad)
    assert bad.read_bytes() == before


def test_a_npy_saved_under_an_npz_name_is_a_checkpoint_error(tmp_path):
    path = tmp_path / "map.npz"
    with open(path, "wb") as f:
        np.save(f, np.zeros(3))
    with pytest.raises(CheckpointError, match="a single numpy array, not a checkpoint"):
        VisuomotorSOM.load(path)
    with pytest.raises(CheckpointError, match="a single numpy array"):
        NATEnet.load(path)


# ------------------------------------------------------------------------------------ NATEnet
def net() -> NATEnet:
    n = NATEnet(input_dim=2, output_shape=(2, 2))
    n.learn(np.array([0.1, 0.2]), np.array([0.01, 0.02]), np.array([0.02, -0.01]))
    return n


def _net_state(n: NATEnet):
    return n.centres.copy(), n.widths.copy(), n.outputs.copy(), n.steps


@pytest.mark.parametrize(
    "call",
    [
        lambda n: n.learn(np.array([1e200, 0.0]), np.array([0.01, 0.0]), np.array([0.02, 0.0])),
        lambda n: n.learn(np.array([0.1, 0.0]), np.array([1e200, 0.0]), np.array([0.02, 0.0])),
        lambda n: n.learn(np.array([0.1, 0.0]), np.array([0.01, 0.0]), np.array([1e300, 0.0])),
        lambda n: n.predict(np.array([0.0, -1e155])),
    ],
    ids=["x", "dtheta", "dx", "predict"],
)
def test_natenet_overflowing_inputs_are_refused_and_the_net_is_unchanged(call):
    n = net()
    before = _net_state(n)
    with pytest.raises(ValueError, match=r"beyond 1000 \(rad or m\)"):
        call(n)
    for a, b in zip(_net_state(n), before, strict=True):
        np.testing.assert_array_equal(a, b)
    assert np.isfinite(n.outputs).all()


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [({"lam": np.inf}, "lam"), ({"eta": np.nan}, "eta"), ({"tau": np.inf}, "tau"),
     ({"max_nodes": 2.5}, "max_nodes"), ({"output_shape": (6, 0)}, "output_shape"),
     ({"input_dim": np.nan}, "input_dim")],
)  # fmt: skip
def test_natenet_constructor_refuses_non_finite_or_absurd_numbers(kwargs, named):
    with pytest.raises(ValueError, match=named):
        NATEnet(**kwargs)


NET_DAMAGE = {
    "NaN outputs": lambda c: c.__setitem__("outputs", np.full_like(c["outputs"], np.nan)),
    "wrong centres shape": lambda c: c.__setitem__("centres", np.zeros((1, 5))),
    "widths missing": lambda c: c.pop("widths"),
    "negative width": lambda c: c.__setitem__("widths", -c["widths"]),
    "steps as float": lambda c: c.__setitem__("steps", np.array(1.5)),
    "unknown option": _config(lambda k: k.__setitem__("gamma", 1.0)),
    "lam as text": _config(lambda k: k.__setitem__("lam", "big")),
}


@pytest.mark.parametrize("edit", NET_DAMAGE.values(), ids=NET_DAMAGE.keys())
def test_natenet_load_raises_checkpoint_error_for_every_damage(tmp_path, edit):
    path = net().save(tmp_path / "net.npz")
    bad = _rewrite(path, tmp_path, "bad.npz", edit)
    with pytest.raises(CheckpointError, match=r"bad\.npz"):
        NATEnet.load(bad)
