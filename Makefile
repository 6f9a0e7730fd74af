# Two entry points for a newcomer: `make demo` and `make test`.
# Each creates .venv if missing (Python 3.11 + pip only), installs the project with every extra, and runs.
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# Python caches the bytecode it compiles (__pycache__): a machine that sets
# PYTHONDONTWRITEBYTECODE (ours do) would compile numpy, scipy, rclpy and drs from source in
# every process the tests start (importing the node: 1.2 s against 0.5 s cached).
unexport PYTHONDONTWRITEBYTECODE
# DDS never leaves loopback on these machines; rclpy needs a writable log dir.
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export ROS_LOG_DIR ?= $(CURDIR)/.ros-log

.PHONY: demo test venv lint bench clean clean-cache

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# tf2_msgs and control_msgs have no PyPI wheel: interfaces/build.py builds them from upstream's
# definitions with the ROS build tools of interfaces/build-requirements.txt (docs/ros.md).
INTERFACES := $(wildcard interfaces/*/package.xml interfaces/*/CMakeLists.txt interfaces/*/msg/*.msg \
	interfaces/*/action/*.action) interfaces/build.py interfaces/wheel_targets.cmake \
	interfaces/build-requirements.txt

# --no-compile: pip would byte-compile every installed module (~12 s of a fresh install); Python
# compiles the ones a process imports, once, on first import (PYTHONDONTWRITEBYTECODE unset above).
$(STAMP): pyproject.toml $(INTERFACES) | $(BIN)/python
	$(BIN)/python -m pip install --quiet --no-compile --upgrade pip
	$(BIN)/python -m pip install --quiet --no-compile -e ".[ros,plots,dev,fast,fleet]" -r interfaces/build-requirements.txt
	$(BIN)/python interfaces/build.py --quiet
	touch $(STAMP)

# numba's on-disk cache is emptied whenever a model source changed since it was last emptied:
# numba checks only the file of the function it compiled, so a kernel edited in
# drs_model/kernels.py would leave the builds that inline it from other files (the gufuncs, the
# study's loops, the tests' own) stale. The demo compiles the little it uses on demand (~9 s in
# all); the tests need it all, filled first by two processes, a share each (the two cores), so
# that no test's node process compiles on a cold cache.
NUMBA_FRESH := $(VENV)/.numba-fresh
$(NUMBA_FRESH): $(STAMP) $(shell find drs_model -name '*.py')
	$(MAKE) --no-print-directory clean-cache
	touch $(NUMBA_FRESH)

NUMBA_STAMP := $(VENV)/.numba-cache
$(NUMBA_STAMP): $(NUMBA_FRESH)
	$(BIN)/python -m drs_model.compiled --part 1/2 & first=$$!; \
	$(BIN)/python -m drs_model.compiled --part 2/2; second=$$?; wait $$first && exit $$second
	touch $(NUMBA_STAMP)

venv: $(STAMP) $(NUMBA_STAMP)

demo: $(STAMP) $(NUMBA_FRESH)
	$(BIN)/drs-demo

# two workers, each stealing tests from the other when it runs out (8:02 on a fresh clone against
# 8:35 with a whole file per worker); the 25 slowest tests at the end (DURATIONS=0: every test,
# for benchmarks/suite_files.py's table in docs/layout.md)
TEST_WORKERS ?= 2
DURATIONS ?= 25
test: $(STAMP) $(NUMBA_STAMP)
	ROS_PYTHON_CHECK_FIELDS=1 $(BIN)/python -m pytest -n $(TEST_WORKERS) --dist worksteal --durations=$(DURATIONS)

lint: $(STAMP)
	$(BIN)/ruff check drs_model drs_ros tests benchmarks interfaces

bench: $(STAMP) $(NUMBA_STAMP)
	$(BIN)/python benchmarks/work_precision.py

# every numba build cached in the tree (make venv, demo, test and bench do it after a model edit)
clean-cache:
	find drs_model tests benchmarks -name '*.nbi' -delete -o -name '*.nbc' -delete

clean: clean-cache
	rm -rf $(VENV) .ros-log .pytest_cache
