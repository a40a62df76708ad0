"""``--controller`` of video.py: names, a map, a run folder; anything else is refused with one line
and exit status 2 before any work (no env built, nothing written)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from learners.persistence import save_npz

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"


def _video(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    command = [sys.executable, str(SCRIPTS / "video.py"), "--out", "v.mp4", *args]
    return subprocess.run(command, capture_output=True, text=True, check=False, cwd=cwd)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((), "the following arguments are required: --controller"),
        (("--controller", "runs/none"), "runs/none does not exist; pass a train.py run folder"),
        (("--controller", "nonsense"), "wants random | analytic"),
        (("--controller", "empty"), "empty is a folder without checkpoint.npz"),
        (("--controller", "missing.npz"), "missing.npz does not exist"),
    ],
)
def test_a_bad_controller_is_one_line_before_any_work(args, message, tmp_path):
    (tmp_path / "empty").mkdir()
    result = _video(*args, cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    assert message in result.stderr.strip().splitlines()[-1]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty"]  # nothing written


def test_a_run_folder_stands_for_its_map(tmp_path):
    from envs.cli.controllers import controller_spec

    run = tmp_path / "run"
    run.mkdir()
    save_npz(run / "checkpoint.npz", "VisuomotorSOM", 1, {}, {})
    assert controller_spec(str(run)) == str(run / "checkpoint.npz")
    assert controller_spec("analytic") == "analytic"
