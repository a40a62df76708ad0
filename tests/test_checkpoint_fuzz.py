"""Damaged checkpoints: random bytes anywhere (array data, ``.npy`` headers, the zip's local
headers and central directory), truncations. Every damaged file either raises
``CheckpointError`` or loads a map identical to the one saved: no other exception, no silently
different map. ``make soak`` (``VISUOMOTOR_SOAK=1``) runs ten times the cases of ``make test``.
"""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from learners import CheckpointError, VisuomotorSOM
from learners.persistence import save_npz

from helpers import one_line_error, run_script

CASES = 2000 if os.environ.get("VISUOMOTOR_SOAK") else 200


def trained_map() -> VisuomotorSOM:
    """A small map that has learned from a few random trials (arrays away from their start)."""
    rng = np.random.default_rng(5)
    som = VisuomotorSOM(np.zeros(3), np.ones(3), lattice=(3, 3, 2), input_dim=4, rng=1)
    for _ in range(20):
        u, v0, v1 = rng.uniform(0.2, 0.8, (3, 4))
        theta0 = som.act(u)
        theta1 = som.act(u, v0, explore=True)
        som.learn(u, theta0, v0, theta1, v1)
    return som


def structure_offsets(blob: bytes) -> np.ndarray:
    """Byte offsets of the zip structure: each member's local header (30 bytes and its name) and
    the central directory to the end of the file."""
    with zipfile.ZipFile(io.BytesIO(blob)) as archive:
        spans = [
            range(i.header_offset, i.header_offset + 30 + len(i.filename))
            for i in archive.infolist()
        ]
        spans.append(range(archive.start_dir, len(blob)))
    return np.concatenate([np.array(s) for s in spans])


def damage(blob: bytes, rng: np.random.Generator, structure: np.ndarray) -> bytes:
    data = bytearray(blob)
    kind = rng.integers(3)
    if kind == 0:  # truncation
        return bytes(data[: rng.integers(len(data))])
    places = structure if kind == 1 else np.arange(len(data))
    for at in rng.choice(places, size=rng.integers(1, 5)):
        data[at] = (data[at] + rng.integers(1, 256)) % 256  # always a different byte
    return bytes(data)


def same_map(a: VisuomotorSOM, b: VisuomotorSOM) -> bool:
    (ca, xa), (cb, xb) = a.state(), b.state()
    return (
        ca == cb
        and xa.keys() == xb.keys()
        and all(x.dtype == xb[k].dtype and np.array_equal(x, xb[k]) for k, x in xa.items())
    )


def test_every_damaged_checkpoint_is_refused_or_loads_identically(tmp_path: Path):
    som = trained_map()
    som.save(tmp_path / "checkpoint.npz")
    blob = (tmp_path / "checkpoint.npz").read_bytes()
    structure = structure_offsets(blob)
    rng = np.random.default_rng(2024)
    refused = identical = 0
    for case in range(CASES):
        path = tmp_path / f"damaged_{case}.npz"
        path.write_bytes(damage(blob, rng, structure))
        try:
            loaded = VisuomotorSOM.load(path)
        except CheckpointError as exc:
            assert str(path) in str(exc) and "\n" not in str(exc)
            refused += 1
        else:
            assert same_map(loaded, som), f"case {case} loaded a different map"
            identical += 1
        path.unlink()
    print(f"{CASES} damaged checkpoints: {refused} refused, {identical} loaded identically")
    assert refused > CASES // 2  # the damage was real: most of it is caught


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("compress_type", zipfile.ZIP_DEFLATED, "compressed or encrypted"),
        ("compress_type", zipfile.ZIP_LZMA, "compressed or encrypted"),
        ("flag_bits", 0x1, "compressed or encrypted"),
    ],
)
def test_members_save_never_writes_are_refused_by_name(tmp_path, field, value, message):
    """The zip directory's compression method and encryption flag, rewritten with valid CRCs:
    formats ``save`` never writes are refused, not handed to a decompressor."""
    som = trained_map()
    som.save(tmp_path / "checkpoint.npz")
    with (
        zipfile.ZipFile(tmp_path / "checkpoint.npz") as src,
        zipfile.ZipFile(tmp_path / "bad.npz", "w") as dst,
    ):
        for info in src.infolist():
            payload = src.read(info)
            if field == "compress_type":
                dst.writestr(info.filename, payload, compress_type=value)
            else:
                dst.writestr(info, payload)
    if field == "flag_bits":  # set the flag in every central directory entry by hand
        raw = bytearray((tmp_path / "bad.npz").read_bytes())
        at = raw.find(b"PK\x01\x02")
        while at >= 0:
            raw[at + 8] |= value
            at = raw.find(b"PK\x01\x02", at + 4)
        (tmp_path / "bad.npz").write_bytes(bytes(raw))
    with pytest.raises(CheckpointError, match=message):
        VisuomotorSOM.load(tmp_path / "bad.npz")


def crafted(tmp_path: Path, change) -> Path:
    """The saved map with ``change(config, arrays)`` applied, written with valid CRCs."""
    config, arrays = trained_map().state()
    change(config, arrays)
    return save_npz(tmp_path / "crafted.npz", "VisuomotorSOM", 1, config, arrays)


def _huge_lattice(config, arrays):
    config["lattice"] = [100_000] * 3  # w stays small: no allocation may follow the lattice


def _absurd_a(config, arrays):
    arrays["A"] = arrays["A"] * 0 + 1e250  # finite, but beyond anything a trial can teach


def _negative_t(config, arrays):
    config["t"] = -3


def _unknown_protocol(config, arrays):
    config["protocol"] = "hebb"


@pytest.mark.parametrize("change", [_huge_lattice, _absurd_a, _negative_t, _unknown_protocol])
def test_crafted_settings_with_valid_crcs_are_refused(tmp_path, change):
    with pytest.raises(CheckpointError) as refused:
        VisuomotorSOM.load(crafted(tmp_path, change))
    assert "\n" not in str(refused.value)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("env", "Pendulum-v1", "env is 'Pendulum-v1'"),
        ("eval_trials", -3, "eval_trials is -3"),
        ("lattice", [100_000, 100_000, 100_000], "the map's arrays"),
        ("protocol", "hebb", "protocol"),
    ],
)
def test_a_run_with_crafted_settings_is_refused_by_resume_and_evaluate(
    tmp_path, field, value, message
):
    """A training run's stored configuration passes the same guards as the command line:
    ``train.py --resume`` and ``evaluate.py --run`` end in one line, before any work."""
    from envs.harness.checkpoint import read_unit, write_unit
    from envs.harness.training import RunConfig, Trainer

    out = tmp_path / "run"
    Trainer(RunConfig.of(trials=1, lattice=(2, 2, 2), eval_every=1, eval_trials=2), out).close()
    path = out / "checkpoint.npz"
    run, sim_state = read_unit(path)
    write_unit(path, VisuomotorSOM.load(path), {**run, "config": {**run["config"], field: value}},
               sim_state)  # fmt: skip
    for script, args in (
        ("train", ["--out", str(out), "--resume"]),
        ("evaluate", ["--run", str(out)]),
    ):
        line = one_line_error(run_script(script, *args, "--targets", "2") if script == "evaluate"
                              else run_script(script, *args))  # fmt: skip
        assert "damaged" in line or message in line, line
