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

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	@echo "installing visuomotor and its dependencies into .venv (about 2 minutes)"
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $@

demo: $(VENV)/.installed
	$(BIN)/python scripts/demo.py --out runs/demo

test: $(VENV)/.installed
	$(BIN)/python -m pytest -q -n 2 --dist loadfile --ignore=tests/test_rl.py  # rl: make test-rl

# The long fault tests: ten times the signals of the kill test and the damaged checkpoints of
# the fuzz test in `make test`.
soak: $(VENV)/.installed
	VISUOMOTOR_SOAK=1 $(BIN)/python -m pytest -q -rP -n 2 tests/test_kill.py tests/test_checkpoint_fuzz.py

# The rl extra (Stable-Baselines3 and torch's CPU build) and its tests.
$(VENV)/.installed-rl: $(VENV)/.installed
	@echo "installing the rl extra (Stable-Baselines3, torch CPU) into .venv (a few minutes)"
	$(BIN)/python -m pip install --quiet -e ".[dev,rl]"
	touch $@

test-rl: $(VENV)/.installed-rl
	$(BIN)/python -m pytest -q -rs tests/test_rl.py

# The documentation site (extra "docs"): mkdocs.yml, pages in docs/, built into site/; strict:
# a broken link, reference or docstring fails the build.
$(VENV)/.installed-docs: $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[dev,docs]"
	touch $@

docs: $(VENV)/.installed-docs
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

lint: $(VENV)/.installed
	$(BIN)/ruff format --check .
	$(BIN)/ruff check .

# Sweeps on Ray: the extra "sweep" in the same venv.
$(VENV)/.sweep: $(VENV)/.installed
	@echo "installing the sweep extra (Ray) into .venv (a few minutes)"
	$(BIN)/python -m pip install --quiet -e ".[dev,sweep]"
	touch $@

test-sweep: $(VENV)/.sweep
	$(BIN)/python -m pytest -q -rs tests/test_sweep.py

# 2 arms × 4 lattice sizes × 2 seeds, short training, on a local Ray instance (2 CPUs).
sweep-demo: $(VENV)/.sweep
	$(BIN)/python scripts/sweep.py --grid robot=riacs,puma --grid lattice=3,4,6,8 \
		--grid seed=0,1 --grid trials=1500 --grid eval_trials=100 --grid eval_every=500 \
		--out runs/sweep-demo

bench: $(VENV)/.installed
	$(BIN)/python scripts/bench.py all

clean:
	rm -rf $(VENV) runs .pytest_cache .ruff_cache

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
