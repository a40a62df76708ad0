"""The command lines explain themselves: help with defaults and the whole description, values
checked by argparse, user errors as one line with status 2, progress on stderr, line-buffered
output, no internal acceptance wording, files readable by others."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from learners.persistence import write_atomic

from helpers import SCRIPTS, one_line_error

COMMANDS = sorted(
    p.stem for p in SCRIPTS.glob("[!_]*.py")
)  # a program's name has no leading underscore


def _run(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, check=False, **kw
    )


@pytest.mark.parametrize("name", COMMANDS)
def test_every_script_explains_itself_with_defaults_and_its_whole_description(name):
    result = _run(str(SCRIPTS / f"{name}.py"), "--help")
    assert result.returncode == 0, result.stderr
    wrapper = (SCRIPTS / f"{name}.py").read_text()
    doc = importlib.import_module(wrapper.split("from ")[1].split(" import")[0]).__doc__
    last = [line.strip() for line in doc.strip().splitlines() if line.strip()][-1]
    assert last in result.stdout  # the description is not cut
    options = re.findall(r"^  --(?!help)[\w-]+.*(?:\n {6,}\S.*)*", result.stdout, re.M)
    for option in options:
        flag = re.match(r"  --[\w-]+(?![\w-])(?! [A-Z{\[])", option)  # no value: nothing to default
        assert "default" in option or "required" in option or "--help" in option or flag
    assert "(default: None)" not in result.stdout and "(default: (" not in result.stdout
    for command in re.findall(r"^\s*(\S*python\S*) scripts/", doc, re.M):
        assert command == ".venv/bin/python"  # runs as written, without an activated venv


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["train.py", "--eval-every", "0"], "--eval-every: wants an integer > 0, got '0'"),
        (["train.py", "--checkpoint-every", "0"], "--checkpoint-every: wants an integer > 0"),
        (["train.py", "--eval-trials", "0"], "--eval-trials: wants an integer > 0"),
        (["train.py", "--env", "Pendulum-v1"], "--env: invalid choice: 'Pendulum-v1'"),
        (["video.py", "--env", "PumaTrack-v0"], "--env: invalid choice: 'PumaTrack-v0'"),
        (["video.py", "--fps", "nan"], "--fps: wants a finite number > 0"),
        (["evaluate.py", "--targets", "-5", "--controller", "random"], "--targets: wants"),
        (["bench.py", "all", "--steps", "3"], "'all' runs each benchmark with its defaults"),
        (["evaluate.py", "--run", "/nonexistent/run"], "does not exist; pass the --out folder"),
    ],
)
def test_bad_values_and_user_errors_are_one_line_with_status_2(args, message, tmp_path):
    result = _run(str(SCRIPTS / args[0]), *args[1:], cwd=tmp_path)
    assert message in one_line_error(result)
    assert not any(tmp_path.iterdir())  # nothing written


def test_stdout_is_line_buffered_when_piped():
    code = "import sys; from envs.cli import common as cli; "
    code += "cli.run(lambda: print(sys.stdout.line_buffering))"
    assert _run("-c", code).stdout.strip() == "True"


def test_video_shows_progress_on_stderr(tmp_path):
    result = _run(str(SCRIPTS / "video.py"), "--env", "RiacsReach-v0", "--controller", "random",
                  "--trials", "2", "--sensing", "project", "--control", "kinematic",
                  "--out", str(tmp_path / "v.mp4"))  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert re.search(r"video: +\d+%.*trial", result.stderr), result.stderr


def test_reports_say_what_happened_not_whether_a_goal_was_met():
    from envs.studies import env_speed, natenet_tracking

    row = {"env": "RiacsReach-v0", "sensing": "render", "control": "servo", "steps_per_s": 10.0,
           "ms_per_step": 100.0, "ratio_to_peer": None}  # fmt: skip
    results = {"peer": {"steps_per_s": 1000.0}, "rows": [row], "image": [320, 240],
               "sense_ms": {}}  # fmt: skip
    text = env_speed.format_table(results)
    summary = {"position_mm_mean": 1.0, "position_mm_max": 2.0, "orientation_deg_mean": 0.5,
               "command_time_us": 1.0, "step_time_us": 2.0}  # fmt: skip
    metrics = {"tracking": {"NATEnet": {"circle": summary}},
               "acceptance": {**summary, "nodes": 40, "passed": True}}  # fmt: skip
    import contextlib
    import io

    with contextlib.redirect_stdout(io.StringIO()) as out:
        natenet_tracking.report(metrics)
    for report in (text, out.getvalue()):
        assert not re.search(r"\b(PASS|FAIL|met|missed|goal)\b", report), report


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o077, 0o600)])
def test_written_files_get_the_mode_open_would_give(tmp_path, umask, mode):
    old = os.umask(umask)
    try:
        path = write_atomic(tmp_path / "a.npz", lambda f: np.save(f, np.zeros(2)))
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == mode


def test_a_long_message_is_one_line_that_keeps_its_start_and_its_end():
    from envs.cli.common import short

    array = np.array2string(np.arange(2000) * 1e-3, threshold=10**6)  # 160 lines, 16 KB
    text = short(f"w is damaged: {array}; restore it from a copy")
    assert "\n" not in text and len(text) == 200
    assert text.startswith("w is damaged: [0.") and text.endswith("; restore it from a copy")
    folder = "/" + "/".join(["a_long_folder_name"] * 12)  # 229 characters of folders
    path = f"{folder}/checkpoint.npz"
    assert short(f"{path}: damaged; restore it") == f"{path}: damaged; restore it"  # not cut
