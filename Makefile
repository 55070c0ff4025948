# proleg: `make run` sets up .venv and runs the main job; `make test` sets up and runs the tests.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test test-slow bench docs venv clean

$(BIN)/python:
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install -q -e ".[test]"
	touch $(STAMP)

venv: $(STAMP)

run: $(STAMP)
	$(BIN)/proleg run hyq-drop

# Test modules run in parallel worker processes (pytest-xdist), one module per worker so its
# shared fixtures compile once: compiling is most of the suite's time, and on the 2-core CI
# machine two workers took a cold run from 14.4 to 10.8 min. `pytest` alone runs serially.
XDIST := -n auto --maxprocesses 4 --dist loadfile

test: $(STAMP)
	$(BIN)/python -m pytest $(XDIST)

test-slow: $(STAMP)
	$(BIN)/python -m pytest $(XDIST) -m slow

bench: $(STAMP)
	$(BIN)/python bench/chain.py
	$(BIN)/python bench/bushing_pendulum.py

# The documentation site into site/ (mkdocs-material; the pages' examples run during the build;
# the test extra carries the docs tools).
docs: $(STAMP)
	PYTHONPATH=src $(BIN)/python -m mkdocs build --strict

clean:
	rm -rf $(VENV) results site .pytest_cache
