"""The committed locks against pyproject.toml (each lock pins every requirement of its extras
inside their ranges, with hashes, and the shared packages alike in every lock), and the timings
that the README and the getting-started page quote against the table that measured them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import tomllib
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
#: Each lock and the extras it installs beside the core dependencies (the Makefile's `lock`).
LOCKS = {"core": [], "dev": ["dev"], "rl": ["dev", "rl"], "sweep": ["dev", "sweep"],
         "docs": ["dev", "docs"]}  # fmt: skip
PIN = re.compile(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==(\S+)", re.M)


def pins(name: str) -> dict[str, str]:
    return {
        canonicalize_name(p): v
        for p, v in PIN.findall((ROOT / "locks" / f"{name}.txt").read_text())
    }


def requirements(extras: list[str]) -> list[Requirement]:
    lines = PYPROJECT["dependencies"] + [
        r for e in extras for r in PYPROJECT["optional-dependencies"][e]
    ]
    return [Requirement(line) for line in lines]


@pytest.mark.parametrize("lock", LOCKS)
def test_each_lock_pins_every_requirement_inside_its_range(lock):
    pinned = pins(lock)
    for requirement in requirements(LOCKS[lock]):
        name = canonicalize_name(requirement.name)
        assert name in pinned, f"locks/{lock}.txt does not pin {name}: run make lock"
        assert requirement.specifier.contains(pinned[name], prereleases=True), (
            f"locks/{lock}.txt pins {name}=={pinned[name]} outside {requirement}: run make lock"
        )


@pytest.mark.parametrize("lock", LOCKS)
def test_every_pin_carries_a_hash(lock):
    text = (ROOT / "locks" / f"{lock}.txt").read_text()
    entries = re.split(r"\n(?=[A-Za-z0-9])", text.split("\n", 2)[2])  # after the header
    assert entries and all("--hash=sha256:" in e for e in entries if PIN.match(e))
    assert len([e for e in entries if PIN.match(e)]) == len(pins(lock))


def test_the_locks_agree_on_the_packages_they_share():
    """The extras go into one venv on top of the dev lock: a package must not change version."""
    dev = pins("dev")
    for lock in ("rl", "sweep", "docs"):
        other = pins(lock)
        moved = {n: (v, other[n]) for n, v in dev.items() if n in other and other[n] != v}
        assert moved == {}, f"locks/{lock}.txt moves dev packages: {moved}"
        assert set(dev) <= set(other), f"locks/{lock}.txt lacks {set(dev) - set(other)}"


def _timing(text: str, command: str) -> str:
    found = re.search(rf"`{command}`[^|\n]*?\b((?:\d+ min )?\d+ s)\b", text)  # "53 s" too
    assert found, f"no time for `{command}`"
    return found.group(1)


def test_readme_and_getting_started_quote_the_measured_timings():
    table = (ROOT / "docs" / "timings.md").read_text()
    rows = {
        c: re.search(rf"\| `{c}` \| ([^|]+) \|", table).group(1).strip()
        for c in ("make test", "make demo")
    }
    cores = re.search(r"on (\d+) cores", table).group(1)
    for page in ("README.md", "docs/getting-started.md"):
        text = (ROOT / page).read_text()
        for command, took in rows.items():
            assert _timing(text, command) == took, (
                f"{page}: `{command}` differs from docs/timings.md"
            )
        assert f"{cores} cores" in text and "timings.md" in text, page
