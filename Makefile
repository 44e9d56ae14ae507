# tribo: one-command set-up, test, demo and benchmarks.
#
#   make demo    the main job: the simulated rig on the live graph, recorded,
#                analysed, reported (sets everything up first if needed)
#   make test    the test suite (sets everything up first if needed)
#
# Other targets: setup, build, bench, lint, clean, distclean.
# Everything is installed into the project-local virtual environment .venv;
# nothing is written outside this directory.

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help

ROOT := $(abspath $(dir $(lastword $(MAKEFILE_LIST))))
VENV := $(ROOT)/.venv
PY := $(VENV)/bin/python
PYTHON ?= $(shell command -v python3.11 || command -v python3)
NUMERIC_STAMP := $(VENV)/.numeric-stamp
UV := $(VENV)/bin/uv
DEPS_STAMP := $(VENV)/.deps-stamp
WARM_STAMP := $(ROOT)/log/.warmup-stamp
BUILD_STAMP := $(ROOT)/install/.build-stamp
PKG_FILES := $(wildcard src/*/package.xml src/*/setup.py src/*/setup.cfg src/*/CMakeLists.txt \
	src/tribo_msgs/msg/*.msg src/*/launch/*.py config/*)
COLCON_ENV := AMENT_PREFIX_PATH=$(VENV) CMAKE_PREFIX_PATH=$(VENV) PATH=$(VENV)/bin:$$PATH
IN_ENV := source $(ROOT)/env.sh &&
# What the targets write stays inside the project: temporary files (pytest's, dask's,
# the benchmarks' scenario folders), the ROS 2 logs and matplotlib's cache go under log/.
export TMPDIR := $(ROOT)/log/tmp
export ROS_LOG_DIR := $(ROOT)/log/ros
export MPLCONFIGDIR := $(ROOT)/log/mpl
PYTEST_ARGS ?=
# test processes (pytest-xdist): the suite waits much on subprocesses and DDS, so
# three workers on two cores finish sooner (pytest alone: 203 s against 215-248 s);
# an idle worker steals queued tests from a busy one (--dist worksteal: 207 and 214 s
# against 231 and 221 s with the default load balancing, runs alternated)
PYTEST_JOBS ?= 3
PYTEST_DIST ?= worksteal

.PHONY: help setup build test typecheck fuzz lint bench demo clean distclean

# The exported TMPDIR exists before any recipe that may write temporary files runs.
$(TMPDIR):
	@mkdir -p $@

help:
	@echo 'make demo   - run the demo on the simulated rig (main job)'
	@echo 'make test   - run the tests'
	@echo 'make setup  - install .venv and build the workspace (done by demo/test as needed)'
	@echo 'make bench  - run the benchmarks (speed and accuracy figures)'
	@echo 'make lint   - ruff, mypy and the dead-code check (vulture)'
	@echo 'make fuzz   - the property-based bad-input suite, long profile (10,000 inputs per command)'

# Set-up in two lines of work on the two cores (make -j2): the numerical packages first
# (numpy, scipy, numba: what the numba warm-up needs), then the warm-up of the compiled
# cores (45 s on one core) and the scenario generator's beside the rest of the packages
# and the colcon build (and mypy, under make test).
setup:
	@$(MAKE) -s -j2 --no-print-directory $(ROOT)/.setup-done

$(ROOT)/.setup-done: $(WARM_STAMP) $(BUILD_STAMP)
	@touch $@

# The pinned packages are installed by uv (itself pinned in constraints.txt and installed
# by pip): the same set as pip's, in 34 s against pip's 74 s. They are compiled to bytecode
# at install, as pip does: where PYTHONDONTWRITEBYTECODE is set, nothing else would write
# it, and every process would compile what it imports. uv's cache lies in .venv.
UV_INSTALL := UV_CACHE_DIR=$(VENV)/.uv-cache $(UV) pip install -q --compile-bytecode --python $(PY)

$(NUMERIC_STAMP): requirements.txt constraints.txt | $(TMPDIR)
	@echo '[setup] virtual environment and pinned packages (.venv)'
	@v=$$($(PYTHON) -c 'import sys; print("%d.%d" % sys.version_info[:2])'); \
	  if [ "$$v" != "3.11" ]; then echo "setup: Python 3.11 is required for the ROS 2 Jazzy wheels (found $$v at $(PYTHON))" >&2; exit 2; fi
	@[ -x $(PY) ] || $(PYTHON) -m venv $(VENV)
	@$(PY) -m pip install -q --disable-pip-version-check uv -c constraints.txt 2>&1 | grep -v '^WARNING: Location' || true
	@[ -x $(UV) ] || { echo 'setup: uv could not be installed (see pip output above)' >&2; exit 2; }
	@$(UV_INSTALL) numpy scipy numba PyYAML -c constraints.txt \
	  || { echo 'setup: package installation failed (see uv output above)' >&2; exit 2; }
	@touch $@

$(DEPS_STAMP): $(NUMERIC_STAMP) requirements.txt constraints.txt tools/fix_ros_wheels.py
	@$(UV_INSTALL) -r requirements.txt -c constraints.txt \
	  || { echo 'setup: package installation failed (see uv output above)' >&2; exit 2; }
	@$(PY) -c 'import rclpy, numba, scipy, rosbags, serial, can, cantools' \
	  || { echo 'setup: package installation failed: a package does not import' >&2; exit 2; }
	@$(PY) tools/fix_ros_wheels.py
	@touch $@

# The numba warm-up (pure-Python cores from src/, one core): compiled once here, not by
# the first node, test or demo; then one scenario of the independent generator
# (validation/tribo_scenarios), whose own compiled integrator the tests' records need:
# compiled once here, not by every test worker at once.
$(WARM_STAMP): $(NUMERIC_STAMP) $(PKG_FILES) | $(TMPDIR)
	@echo '[setup] numba warm-up of the compiled cores (beside the packages and the build)'
	@mkdir -p log
	@PYTHONPATH=$(ROOT)/src/tribo_common:$(ROOT)/src/tribo_estimation $(PY) tools/warmup.py \
	  > log/warmup.txt 2>&1 || { cat log/warmup.txt >&2; echo 'setup: numba warm-up failed (log/warmup.txt)' >&2; exit 2; }
	@cat log/warmup.txt >&2
	@rm -rf log/scenario-warmup; PYTHONPATH=$(ROOT)/validation $(PY) -m tribo_scenarios 5 \
	  --duration 1 --out log/scenario-warmup > log/scenario-warmup.txt 2>&1 \
	  || { cat log/scenario-warmup.txt >&2; echo 'setup: scenario generator warm-up failed (log/scenario-warmup.txt)' >&2; exit 2; }
	@touch $@

# The colcon build of the workspace, then the project's own modules compiled to bytecode
# (src/ and the generator; make test compiles again what changed): where
# PYTHONDONTWRITEBYTECODE is set, every process of the tests would otherwise compile
# what it imports (0.7 s of CPU for a process that imports every module).
COMPILE := $(PY) -m compileall -q -j0 src validation
$(BUILD_STAMP): $(DEPS_STAMP) $(PKG_FILES) | $(TMPDIR)
	@echo '[setup] colcon build of the workspace (install/)'
	@mkdir -p log
	@$(COLCON_ENV) $(VENV)/bin/colcon --log-base log build --symlink-install \
	  --event-handlers console_direct- summary- \
	  --cmake-args -DPython3_EXECUTABLE=$(PY) -DBUILD_TESTING=OFF > log/colcon-build.txt 2>&1 \
	  || { tail -40 log/colcon-build.txt >&2; echo 'setup: colcon build failed (log/colcon-build.txt)' >&2; exit 2; }
	@$(COMPILE)
	@touch $@

build:
	@rm -f $(BUILD_STAMP)
	@$(MAKE) -s setup

MYPY_PATHS := src/tribo_common/tribo_common src/tribo_estimation/tribo_estimation \
	src/tribo_nvct/tribo_nvct src/tribo_drivers/tribo_drivers src/tribo_bringup/tribo_bringup tools bench \
	validation/tribo_scenarios
MYPY := $(VENV)/bin/mypy --no-incremental --cache-dir .mypy_cache/make $(MYPY_PATHS)

# mypy (one core, 25 s; it needs the packages, not the build) runs beside the set-up
# once the packages are in (make -j2: on the core the warm-up leaves), not beside
# pytest, whose workers keep both cores busy; its report follows pytest's, and either
# failing fails the target.
test: | $(TMPDIR)
	@$(MAKE) -s -j2 --no-print-directory $(ROOT)/.setup-done typecheck
	@echo '[test] ruff, vulture, pytest'
	@$(COMPILE)
	@$(IN_ENV) ruff check --no-cache src tests bench tools validation conftest.py
	@$(IN_ENV) vulture
	@$(IN_ENV) rc=0; python -m pytest -q -n $(PYTEST_JOBS) --dist $(PYTEST_DIST) --timeout=600 \
	  $(PYTEST_ARGS) || rc=$$?; \
	  cat log/mypy.txt; mrc=$$(cat log/mypy.rc); \
	  if [ "$$mrc" != 0 ]; then echo 'test: mypy failed (above)' >&2; fi; \
	  [ $$rc -eq 0 ] && [ "$$mrc" = 0 ]

typecheck: $(DEPS_STAMP)
	@mkdir -p log; rc=0; $(MYPY) > log/mypy.txt 2>&1 || rc=$$?; echo $$rc > log/mypy.rc

# Long profile of the property-based bad-input suite (tests/test_fuzz_*.py; make test
# runs its short profile): FUZZ_EXAMPLES generated bad inputs per command (the burst
# property test a quarter of them); FUZZ_LOG=path logs every command run (command,
# exit code, seconds), so a run stopped early still tells how many inputs ran.
FUZZ_EXAMPLES ?= 10000
fuzz: setup | $(TMPDIR)
	@echo '[fuzz] $(FUZZ_EXAMPLES) generated bad inputs per command and decoder'
	@$(IN_ENV) HYPOTHESIS_PROFILE=fuzz HYPOTHESIS_MAX_EXAMPLES=$(FUZZ_EXAMPLES) python -m pytest -q \
	  -n $(PYTEST_JOBS) --timeout=0 --hypothesis-show-statistics tests/test_fuzz_commands.py \
	  tests/test_fuzz_decoders.py tests/test_fuzz_bursts.py

# vulture: the dead-code check (configuration in pyproject.toml, dynamic uses in
# tools/vulture_whitelist.py)
lint: setup
	@$(IN_ENV) ruff check --no-cache src tests bench tools validation conftest.py
	@$(IN_ENV) ruff format --no-cache --check src tests bench tools validation conftest.py
	@$(MYPY)
	@$(IN_ENV) vulture

# the benchmarks that print accuracy figures also write them into docs/validation.md
# (bench/validation_doc.py: one section per benchmark, with the date, commit and command)
bench: setup | $(TMPDIR)
	@$(IN_ENV) for b in bench/bench_*.py; do echo "=== $$b"; TRIBO_WRITE_VALIDATION=1 python $$b; done

demo: setup | $(TMPDIR)
	@$(IN_ENV) python -m tribo_bringup.cli demo

clean:
	rm -rf build install log .setup-done demo_output

distclean: clean
	rm -rf $(VENV)
