"""The wheel: built from the checkout (not editable), installed into a folder of its own and
imported from there alone, every module of the checkout's packages, the models' MJCF files and
READMEs, and a ``run`` function behind every console script."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import sysconfig
import zipfile
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("envs", "learners", "models")
#: setuptools that reads the PEP 639 license string of pyproject.toml (the dev extra pins it).
MIN_SETUPTOOLS = (77,)

#: Run in a child with ``python -S``: no site-packages and so no editable finder of the checkout;
#: sys.path is the installed wheel, then the venv's site-packages for the dependencies.
_IMPORT_ALL = """
import importlib, json, sys
target, deps, modules = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
sys.path[:0] = [target, deps]
files = {}
for name in modules:
    files[name] = importlib.import_module(name).__file__
scripts = {}
for name, value in json.loads(sys.argv[4]).items():
    module, program = value.split(":")  # visuomotor_startup:<name> starts envs.cli.<name>.run
    scripts[name] = callable(getattr(importlib.import_module(module), program, None)) and callable(
        getattr(importlib.import_module("envs.cli." + program), "run", None))
print(json.dumps({"files": files, "scripts": scripts}))
"""


def _setuptools_version() -> tuple[int, ...]:
    try:
        version = metadata.version("setuptools")
    except metadata.PackageNotFoundError:
        return (0,)
    return tuple(int(p) for p in version.split(".")[:2] if p.isdigit())


def _checkout_modules() -> set[str]:
    """Dotted names of every .py file under the packages' folders of the checkout, and the
    top-level modules pyproject.toml lists (``py-modules``)."""
    tomllib = pytest.importorskip("tomllib")
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    names = set(setuptools.get("py-modules", []))
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            names.add(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


def _console_scripts() -> dict[str, str]:
    tomllib = pytest.importorskip("tomllib")
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    if _setuptools_version() < MIN_SETUPTOOLS:
        pytest.skip(
            "building the wheel needs setuptools >= 77 in this environment: "
            "pip install 'setuptools>=77' (the dev extra pins it)"
        )
    out = tmp_path_factory.mktemp("wheel")
    build = [sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation",
             "--quiet", "-w", str(out)]  # fmt: skip
    result = subprocess.run(build, capture_output=True, text=True, check=False, cwd=out)
    assert result.returncode == 0, result.stderr
    (path,) = out.glob("visuomotor-*.whl")
    return path


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    target = tmp_path_factory.mktemp("target")
    install = [sys.executable, "-m", "pip", "install", "--no-deps", "--quiet", "--target",
               str(target), str(wheel)]  # fmt: skip
    result = subprocess.run(install, capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stderr
    return target


def test_the_wheel_holds_every_module_and_the_models_files(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    modules = {
        ".".join(Path(n).with_suffix("").parts[:-1] if n.endswith("__init__.py")
                 else Path(n).with_suffix("").parts)
        for n in names if n.endswith(".py")
    }  # fmt: skip
    assert modules == _checkout_modules()
    for robot in ("puma560", "riacs"):
        for name in (f"{robot}.xml", "scene.xml", "README.md"):
            assert f"models/{robot}/{name}" in names
    data = {n for n in names if n.endswith((".xml", ".md")) and n.startswith(PACKAGES)}
    checkout = {
        str(p.relative_to(ROOT))
        for package in PACKAGES
        for p in (ROOT / package).rglob("*")
        if p.suffix in (".xml", ".md")
    }
    assert data == checkout


def test_every_module_imports_from_the_installed_wheel_alone(installed, tmp_path):
    modules = sorted(_checkout_modules())
    scripts = _console_scripts()
    deps = sysconfig.get_paths()["purelib"]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["MUJOCO_GL"] = os.environ.get("MUJOCO_GL", "egl")
    command = [sys.executable, "-S", "-c", _IMPORT_ALL, str(installed), deps, json.dumps(modules),
               json.dumps(scripts)]  # fmt: skip
    result = subprocess.run(command, capture_output=True, text=True, check=False, cwd=tmp_path,
                            env=env)  # fmt: skip
    assert result.returncode == 0, result.stderr
    found = json.loads(result.stdout.splitlines()[-1])
    assert set(found["files"]) == set(modules)
    outside = {n: f for n, f in found["files"].items() if not Path(f).is_relative_to(installed)}
    assert not outside, f"imported from outside the installed wheel: {outside}"
    assert found["scripts"] == dict.fromkeys(scripts, True)  # each starts a callable ``run``
    assert all(value.startswith("visuomotor_startup:") for value in scripts.values())


def test_the_installed_entry_points_are_the_pyproject_scripts(installed):
    (dist_info,) = installed.glob("visuomotor-*.dist-info")
    text = (dist_info / "entry_points.txt").read_text()
    section = text.split("[console_scripts]")[1].split("[")[0]
    entries = dict(
        (part.strip() for part in line.split("=", 1))
        for line in section.splitlines()
        if "=" in line
    )
    assert entries == _console_scripts()
