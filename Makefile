# The two front-door commands (see README.md): `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
# Headless rendering: EGL (Mesa llvmpipe without a GPU) unless the caller chose a back-end.
export MUJOCO_GL ?= egl

.PHONY: demo test lint bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $@

demo: $(VENV)/.installed
	$(BIN)/python scripts/demo.py --out runs/demo

test: $(VENV)/.installed
	$(BIN)/python -m pytest -q -n 2 --dist loadfile

lint: $(VENV)/.installed
	$(BIN)/ruff format --check .
	$(BIN)/ruff check .

bench: $(VENV)/.installed
	$(BIN)/python scripts/bench.py all

clean:
	rm -rf $(VENV) runs .pytest_cache .ruff_cache
