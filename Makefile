# GenCoords: every target sets up the virtual environment of the Blender it tests first.
#
# BLENDER picks the Blender (as the pip `bpy` module) that `setup`, `test`, `build` and
# `demo` use; each version gets its own virtual environment with the Python and numpy
# that bpy wheel needs. The default, 5.0.1, lives in .venv (requirements.txt).
BLENDER ?= 5.0.1
# What `make test-blender-matrix` and CI run: the oldest Blender the manifest accepts
# (blender_version_min, a test holds them equal) and the latest of each series.
MATRIX  := 4.2.0 4.2.23 4.5.15 5.0.1 5.1.2 5.2.3

SERIES  := $(word 1,$(subst ., ,$(BLENDER))).$(word 2,$(subst ., ,$(BLENDER)))
# bpy 5.1 and later is built for Python 3.13, earlier versions for Python 3.11.
ifneq ($(filter 5.1 5.2 5.3,$(SERIES)),)
PYTHON_VERSION := 3.13
else
PYTHON_VERSION := 3.11
endif
# pythonX.Y from the PATH when it runs (a pyenv shim of a version not selected does
# not), else pyenv's own copy of that version; `make PYTHON=...` overrides.
PYTHON ?= $(firstword $(foreach candidate,python$(PYTHON_VERSION) \
            $(wildcard $(HOME)/.pyenv/versions/$(PYTHON_VERSION).*/bin/python$(PYTHON_VERSION)),\
            $(shell $(candidate) -c "" >/dev/null 2>&1 && echo $(candidate))) python$(PYTHON_VERSION))
# bpy 4.5 and 5.0 are built against numpy 1.x (they fail to import with numpy 2);
# 4.2, 5.1 and 5.2 bring the numpy they need (2.x) themselves.
ifneq ($(filter 4.5 5.0,$(SERIES)),)
NUMPY := "numpy<2"
endif

ifeq ($(BLENDER),5.0.1)
VENV := .venv
REQUIREMENTS := requirements.txt
else
VENV := .venv-$(BLENDER)
REQUIREMENTS := requirements-test.txt
endif
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: help setup test-tools demo test test-core lint build bench bench-core test-blender-matrix environment \
        setup-blender-matrix check-release fuzz clean distclean

## This list: every target with what its `##` comment says.
help:
	@awk '/^## /{text = text (text ? " " : "") substr($$0, 4); next} \
	     /^[a-z][a-z-]*:/ && text {split($$0, t, ":"); printf "  %-22s %s\n", t[1], text} {text = ""}' \
	    $(firstword $(MAKEFILE_LIST))

## The virtual environment of BLENDER (default .venv): bpy, numpy, pytest, ruff, the core editable.
setup: $(STAMP)

$(STAMP): $(REQUIREMENTS) pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
ifeq ($(BLENDER),5.0.1)
	$(PY) -m pip install --quiet -r requirements.txt
else
	$(PY) -m pip install --quiet "bpy==$(BLENDER)" $(NUMPY) -r requirements-test.txt
endif
	# The core as `gencoords`, editable: tests, scripts and pipelines `import gencoords`.
	$(PY) -m pip install --quiet --no-build-isolation --no-deps -e .
	touch $(STAMP)

TOOLS_STAMP := tests/tools/node_modules/.installed

## The tools the tests run besides Python: the Khronos glTF-Validator (npm, the version
## pinned in tests/tools/package-lock.json) checks the .glb a baked rig exports; without
## it that test skips, and fails where CI is set.
test-tools: $(TOOLS_STAMP)

# Without npm (a machine with Python alone) the validator's test skips, except in CI.
$(TOOLS_STAMP): tests/tools/package.json tests/tools/package-lock.json
	@if command -v npm >/dev/null 2>&1 || [ -n "$$CI" ]; then \
	    cd tests/tools && npm ci --no-audit --no-fund && touch node_modules/.installed; \
	else echo "npm not found: the glTF-Validator test will skip (install Node.js to run it)"; fi

## The main job: a headless demo on a built-in default scene.
demo: $(STAMP)
	$(PY) scripts/demo/demo.py

## The whole test suite (core, then the built extension installed into Blender; the
## tests build and validate the zip themselves with this Blender's tools).
test: $(STAMP) $(TOOLS_STAMP)
	$(PY) -m pytest

## The tests that need no Blender (the core, the layout): `pytest -m "not blender"`.
test-core: $(STAMP)
	$(PY) -m pytest -m "not blender"

## ruff (configured in pyproject.toml) over the core, the add-on, the scripts and the tests.
lint: $(STAMP)
	$(PY) -m ruff check .

## The whole suite on every Blender of MATRIX, each in its own virtual environment: set
## up one after another, tested side by side (as many at once as CPUs, MATRIX_JOBS
## overrides), the tests needing no Blender once per Python and numpy pair; prints
## pass/fail counts and wall time per version at the end.
test-blender-matrix: $(TOOLS_STAMP)
	$(PYTHON) scripts/release/test_matrix.py $(if $(MATRIX_JOBS),--jobs $(MATRIX_JOBS)) $(MATRIX)

## The Python and numpy versions of BLENDER's environment, on one line: the matrix runs
## the tests that need no Blender once per pair (they cannot differ between Blenders).
environment: $(STAMP)
	@$(PY) -c "import sys, numpy; print('Python', sys.version.split()[0], 'numpy', numpy.__version__)"

## Only set up the virtual environments of every Blender of MATRIX.
setup-blender-matrix:
	for version in $(MATRIX); do $(MAKE) setup BLENDER=$$version || exit 1; done

## The extension zip, built and validated by Blender's own tools.
build: $(STAMP)
	$(PY) scripts/release/build_extension.py

## Before a release: install the zip into a real Blender and render the demo scene,
## e.g. `make check-release BLENDER_BINARY=~/blender-4.2.23-linux-x64/blender`.
check-release: build
	$(PY) scripts/release/check_release.py $(BLENDER_BINARY)

# CGAL's timings join the core's table once `sh scripts/chroot/cgal_reference.sh` has built its binary.
CGAL_REFERENCE := $(if $(wildcard build/cgal_reference),--cgal build/cgal_reference)

## Speed and memory figures (not part of the tests; docs/BENCHMARKS.md), with CGAL's
## timings beside the core's once `sh scripts/chroot/cgal_reference.sh` has built them.
bench: $(STAMP) build
	$(PY) scripts/benchmarks/bench_core.py --workers --surfaces $(CGAL_REFERENCE)
	$(PY) scripts/benchmarks/bench_blender.py
	$(PY) scripts/benchmarks/bench_artist.py
	$(PY) scripts/benchmarks/bench_local.py
	$(PY) scripts/benchmarks/bench_quads.py
	$(PY) scripts/benchmarks/bench_fixtures.py

## The core's speed table alone (no Blender).
bench-core: $(STAMP)
	$(PY) scripts/benchmarks/bench_core.py --workers --surfaces $(CGAL_REFERENCE)

CASES ?= 200
FIRST_SEED ?= 0
JOBS ?= 1

## The seeded operator fuzz (scripts/fuzz/run.py, docs/ARCHITECTURE.md): CASES random cases
## (default 200) from seed FIRST_SEED, each in a fresh Blender process, JOBS at once; prints
## each failing case's steps and replay command. `make fuzz SEED=123` replays one case.
fuzz: $(STAMP)
ifdef SEED
	$(PY) scripts/fuzz/run.py --replay $(SEED)
else
	nice -n 10 $(PY) scripts/fuzz/run.py --cases $(CASES) --first-seed $(FIRST_SEED) --jobs $(JOBS)
endif

## Build outputs and caches.
clean:
	rm -rf dist build out .pytest_cache .hypothesis

## Build outputs, caches and the virtual environments.
distclean: clean
	rm -rf $(VENV) .venv-*
