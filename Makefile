# The two front-door commands (see README.md): `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
# Headless rendering: EGL (Mesa llvmpipe without a GPU) unless the caller chose a back-end.
export MUJOCO_GL ?= egl

.PHONY: demo test test-rl lint bench soak clean test-sweep sweep-demo docs

$(BIN)/python:
	@echo "creating the virtual environment .venv and updating pip (under a minute)"
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# -- Locked installs ------------------------------------------------------------------------------
# locks/<name>.txt pin every direct and indirect dependency, with hashes, for CPython 3.11 on
# x86-64 Linux: core (the library alone), dev (core + the test tools), and dev with each optional
# extra (rl, sweep, docs). `make lock` writes them from pyproject.toml's ranges; `make test`,
# `make demo` and CI install from them, so a clean clone gets the releases the README's figures
# were measured with. `pip install .` keeps the ranges (see test-min-versions and test-latest).
LOCKS := locks
LOCK_VENV := .venv-lock
UV_VERSION := 0.13.9
LOCK_TARGET := --python-version 3.11 --python-platform x86_64-manylinux_2_28
# Where the rl extra's torch CPU build (torch==...+cpu) is found: this machine keeps it on disk;
# elsewhere PyTorch's CPU wheel index.
TORCH_WHEELS ?= /opt/wheels
COMPILE = $(LOCK_VENV)/bin/uv pip compile pyproject.toml --quiet --generate-hashes $(LOCK_TARGET) \
	--find-links $(TORCH_WHEELS)
PYTEST_ARGS := -q -n 2 --dist loadfile --ignore=tests/test_rl.py  # rl: make test-rl

# pip install from a lock: --require-hashes refuses anything unpinned or altered; the project
# itself goes in without dependencies (all are locked) and with the lock's setuptools.
define install_locked
	$(BIN)/python -m pip install --quiet --require-hashes -r $(LOCKS)/$(1).txt
	$(BIN)/python -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $@
endef

.PHONY: lock test-latest timings
lock:
	test -x $(LOCK_VENV)/bin/uv || ($(PYTHON) -m venv $(LOCK_VENV) \
		&& $(LOCK_VENV)/bin/python -m pip install --quiet uv==$(UV_VERSION))
	$(COMPILE) -o $(LOCKS)/core.txt
	$(COMPILE) --extra dev -o $(LOCKS)/dev.txt
	for extra in rl sweep docs; do \
		$(COMPILE) --extra dev --extra $$extra -o $(LOCKS)/$$extra.txt || exit 1; \
	done

$(VENV)/.installed: $(LOCKS)/dev.txt pyproject.toml | $(BIN)/python
	@echo "installing visuomotor and its locked dependencies into .venv (about 2 minutes)"
	$(call install_locked,dev)

demo: $(VENV)/.installed
	$(BIN)/python scripts/demo.py --out runs/demo

test: $(VENV)/.installed
	$(BIN)/python -m pytest $(PYTEST_ARGS)

# The newest releases that pyproject.toml's ranges allow, in a venv of its own made anew each
# time, and the same tests: what next month's user gets, before they meet it.
LATEST_VENV := .venv-latest
test-latest:
	rm -rf $(LATEST_VENV)
	$(PYTHON) -m venv $(LATEST_VENV)
	$(LATEST_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(LATEST_VENV)/bin/python -m pip install --quiet --upgrade --upgrade-strategy eager -e ".[dev]"
	$(LATEST_VENV)/bin/python -m pip list --format=freeze | grep -iE \
		'^(mujoco|numpy|gymnasium|opencv-python-headless|numba|matplotlib|imageio-ffmpeg)=='
	$(LATEST_VENV)/bin/python -m pytest $(PYTEST_ARGS)

# `make test` and `make demo` on a fresh clone (set-up included), timed, with the machine's
# cores and load: writes docs/timings.md, which the README and docs quote.
timings:
	$(PYTHON) .ci/timings.py --out docs/timings.md

# The long fault tests: ten times the signals of the kill test and the damaged checkpoints of
# the fuzz test in `make test`.
soak: $(VENV)/.installed
	VISUOMOTOR_SOAK=1 $(BIN)/python -m pytest -q -rP -n 2 tests/test_kill.py tests/test_workers_kill.py tests/test_checkpoint_fuzz.py tests/test_run_state_fuzz.py

# The rl extra (Stable-Baselines3 and torch's CPU build) and its tests.
$(VENV)/.installed-rl: $(VENV)/.installed $(LOCKS)/rl.txt
	@echo "installing the rl extra (Stable-Baselines3, torch CPU) into .venv (a few minutes)"
	$(call install_locked,rl)

test-rl: $(VENV)/.installed-rl
	$(BIN)/python -m pytest -q -rs tests/test_rl.py

# The documentation site (extra "docs"): mkdocs.yml, pages in docs/, built into site/; strict:
# a broken link, reference or docstring fails the build.
$(VENV)/.installed-docs: $(VENV)/.installed $(LOCKS)/docs.txt
	$(call install_locked,docs)

docs: $(VENV)/.installed-docs
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

lint: $(VENV)/.installed
	$(BIN)/ruff format --check .
	$(BIN)/ruff check .
	$(BIN)/mypy  # the files in pyproject.toml's [tool.mypy]

# Sweeps and training workers on Ray: the extra "sweep" in the same venv.
$(VENV)/.sweep: $(VENV)/.installed $(LOCKS)/sweep.txt
	@echo "installing the sweep extra (Ray) into .venv (a few minutes)"
	$(call install_locked,sweep)

test-sweep: $(VENV)/.sweep
	$(BIN)/python -m pytest -q -rs tests/test_sweep.py tests/test_ray_workers.py

# 2 arms × 4 lattice sizes × 2 seeds, short training, on a local Ray instance (2 CPUs).
sweep-demo: $(VENV)/.sweep
	$(BIN)/python scripts/sweep.py --grid robot=riacs,puma --grid lattice=3,4,6,8 \
		--grid seed=0,1 --grid trials=1500 --grid eval_trials=100 --grid eval_every=500 \
		--out runs/sweep-demo

bench: $(VENV)/.installed
	$(BIN)/python scripts/bench.py all

clean:
	rm -rf $(VENV) $(LATEST_VENV) $(MIN_VENV) $(LOCK_VENV) runs .pytest_cache .ruff_cache

# The oldest mujoco and gymnasium that pyproject.toml allows (its ">=" read as "=="), in a venv
# of its own, with the tests of the envs and the off-screen rendering.
MIN_VENV := .venv-min
MIN_TESTS := tests/test_rendering.py tests/test_envs.py
.PHONY: test-min-versions

$(MIN_VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(MIN_VENV)
	$(MIN_VENV)/bin/python -m pip install --quiet --upgrade pip
	grep -oE '"(mujoco|gymnasium)>=[0-9.]+"' pyproject.toml | tr -d '"' | sed 's/>=/==/' \
		> $(MIN_VENV)/constraints.txt
	$(MIN_VENV)/bin/python -m pip install --quiet -c $(MIN_VENV)/constraints.txt -e ".[dev]"
	touch $@

test-min-versions: $(MIN_VENV)/.installed
	$(MIN_VENV)/bin/python -c "import mujoco, gymnasium; print('mujoco', mujoco.__version__, \
		'gymnasium', gymnasium.__version__)"
	$(MIN_VENV)/bin/python -m pytest -q $(MIN_TESTS)
