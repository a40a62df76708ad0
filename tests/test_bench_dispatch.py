"""``scripts/bench.py <name>`` hands its options to the benchmark program of that name."""

from __future__ import annotations

import importlib

import pytest

from envs.cli import bench


@pytest.mark.parametrize("name", bench.BENCHMARKS)
def test_the_dispatcher_reaches_each_benchmarks_own_options(name, capsys):
    """``bench.py <name> --help`` prints the help of ``envs.cli.bench_<name>``, whose first
    docstring line it shows."""
    program = importlib.import_module(f"envs.cli.bench_{name}")
    with pytest.raises(SystemExit) as stop:
        bench.main([name, "--help"])
    assert stop.value.code == 0
    assert program.__doc__.splitlines()[0] in capsys.readouterr().out
