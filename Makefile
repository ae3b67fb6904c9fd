# GenCoords: every target sets up the project-local virtual environment first.
PYTHON ?= python3.11
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: setup demo test test-core build bench bench-core clean distclean

setup: $(STAMP)

$(STAMP): requirements.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	touch $(STAMP)

## The main job: a headless demo on a built-in default scene.
demo: $(STAMP)
	$(PY) scripts/demo.py

## The whole test suite (core, then the built extension installed into Blender; the
## tests build and validate the zip themselves).
test: $(STAMP)
	$(PY) -m pytest

test-core: $(STAMP)
	$(PY) -m pytest tests/core

## The extension zip, built and validated by Blender's own tools.
build: $(STAMP)
	$(PY) scripts/build_extension.py

## Speed and memory figures (not part of the tests).
bench: $(STAMP) build
	$(PY) scripts/bench_core.py
	$(PY) scripts/bench_blender.py
	$(PY) scripts/bench_artist.py

bench-core: $(STAMP)
	$(PY) scripts/bench_core.py

## Build outputs and caches; `make distclean` also removes the virtual environment.
clean:
	rm -rf dist build out .pytest_cache .hypothesis

distclean: clean
	rm -rf $(VENV)
