"""The troubleshooting entry (docs/troubleshooting.md) for a foreign ``envs`` package is right:
beside a script that has its own ``envs/`` package, ``gym.make`` does not find this project's
environments, the entry's check prints the other package's path, and ``python -P`` finds this
project's again; and this project's modules imported under a foreign ``envs`` stop with a
one-line ImportError naming it."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import envs

TROUBLESHOOTING = Path(__file__).resolve().parents[1] / "docs" / "troubleshooting.md"
SUBPROCESS_TIMEOUT = 120  # s
SCRIPT = """
import gymnasium as gym
import envs
print(envs.__file__)
try:
    gym.make("RiacsReach-v0", sensing="project")
except gym.error.NameNotFound as exc:
    print("NameNotFound:", exc)
else:
    print("made")
"""


def _run(args: list[str], cwd: Path) -> list[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONSAFEPATH"}
    result = subprocess.run(
        [sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True,
        timeout=SUBPROCESS_TIMEOUT,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stdout.strip().splitlines()


def _readme_check() -> list[str]:
    """The command of the troubleshooting entry, as argv after ``python``."""
    section = TROUBLESHOOTING.read_text().split("# Troubleshooting", 1)[1].split("\n## ", 1)[0]
    command = re.search(r'^ {4}python (-c "[^"]+")$', section, re.MULTILINE)
    assert command is not None, "the troubleshooting entry lost its check"
    return ["-c", command.group(1)[4:-1]]


def test_a_foreign_envs_package_is_found_by_the_readme_check_and_avoided_by_safe_path(tmp_path):
    ours = Path(envs.__file__).resolve()
    theirs = tmp_path / "envs" / "__init__.py"
    theirs.parent.mkdir()
    theirs.write_text("FOREIGN = True\n")
    (tmp_path / "script.py").write_text(SCRIPT)

    first, outcome = _run(["script.py"], tmp_path)
    assert Path(first).resolve() == theirs.resolve()
    assert outcome.startswith("NameNotFound:") and "RiacsReach" in outcome  # the symptom
    (found,) = _run(_readme_check(), tmp_path)
    assert Path(found).resolve() == theirs.resolve()  # the check names the foreign package

    first, outcome = _run(["-P", "script.py"], tmp_path)  # the README's way round it
    assert Path(first).resolve() == ours and outcome == "made"
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (found,) = _run(_readme_check(), elsewhere)
    assert Path(found).resolve() == ours


FOREIGN_EXTENDING = """
import os
# A foreign package that also serves this project's modules (as an editable install's finder
# does for any parent package named envs).
__path__.append(os.environ["OUR_ENVS"])
"""


def test_our_modules_under_a_foreign_envs_package_raise_one_line_naming_it(tmp_path):
    theirs = tmp_path / "envs"
    theirs.mkdir()
    (theirs / "__init__.py").write_text(FOREIGN_EXTENDING)
    env = {**os.environ, "OUR_ENVS": str(Path(envs.__file__).resolve().parent)}
    result = subprocess.run(
        [sys.executable, "-c", "from envs.reach import ReachEnv"], cwd=tmp_path, env=env,
        capture_output=True, text=True, timeout=SUBPROCESS_TIMEOUT,
    )  # fmt: skip
    assert result.returncode != 0
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: the package 'envs' imported here is ")
    assert str(theirs.resolve()) in last and "Troubleshooting" in last
