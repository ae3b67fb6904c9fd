# GenCoords: every target sets up the project-local virtual environment first.
#
# BLENDER picks the pip bpy the tests run on (default 5.0.1, the .venv); any other
# version gets its own .venv-<version> with the Python and numpy that bpy needs:
#   make test BLENDER=4.2.23     make test-blender-matrix
BLENDER ?= 5.0.1
# Latest of each series: 4.2 LTS, 4.5 LTS, 5.0, 5.1, 5.2.
MATRIX  := 4.2.23 4.5.15 5.0.1 5.1.2 5.2.3
SERIES  := $(basename $(BLENDER))
# bpy 5.1 and later are built for Python 3.13, earlier ones for 3.11; 4.5 and 5.0 need
# numpy 1.x (their C API), the others ship for numpy 2.
PYTHON_VERSION := $(if $(filter 5.1 5.2 5.3,$(SERIES)),3.13,3.11)
NUMPY          := $(if $(filter 4.5 5.0,$(SERIES)),numpy<2,numpy>=2)

ifeq ($(BLENDER),5.0.1)
VENV         := .venv
REQUIREMENTS := -r requirements.txt
else
VENV         := .venv-$(BLENDER)
REQUIREMENTS := bpy==$(BLENDER) "$(NUMPY)" pytest hypothesis
endif
PYTHON ?= $(shell scripts/find_python.sh $(PYTHON_VERSION))
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: setup demo test test-core test-blender-matrix build bench bench-core clean distclean

setup: $(STAMP)

$(STAMP): requirements.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet $(REQUIREMENTS)
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

## The whole suite on every Blender of MATRIX, each in its own environment (downloads
## about 400 MB per version the first time); prints a line per version at the end.
test-blender-matrix:
	@failed=""; for version in $(MATRIX); do \
	    start=$$(date +%s); \
	    if $(MAKE) --no-print-directory test BLENDER=$$version; then result=passed; \
	    else result=FAILED; failed="$$failed $$version"; fi; \
	    echo "bpy $$version: $$result in $$(( $$(date +%s) - start )) s" | tee -a .matrix-summary; \
	done; cat .matrix-summary; rm -f .matrix-summary; test -z "$$failed"

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
	rm -rf .venv .venv-*
