# Two entry points for a newcomer: `make demo` and `make test`.
# Each creates .venv if missing (Python 3.11 + pip only), installs the project with every extra, and runs.
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
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

$(STAMP): pyproject.toml $(INTERFACES) | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[ros,plots,dev,fast,fleet]" -r interfaces/build-requirements.txt
	$(BIN)/python interfaces/build.py --quiet
	# numba's on-disk cache, filled once here: no test, demo or node start compiles on a cold cache
	$(BIN)/python -m drs_model.compiled
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(BIN)/drs-demo

test: $(STAMP)
	ROS_PYTHON_CHECK_FIELDS=1 $(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check drs_model drs_ros tests benchmarks interfaces

bench: $(STAMP)
	$(BIN)/python benchmarks/work_precision.py

# numba checks only the file of the function it compiled: after editing drs_model/kernels.py, the
# cached builds of the compiled functions in other files that call a kernel are stale (the tests'
# and benchmarks' own compiled functions too; the RK driver's builds, drs_model/compiled/drivers.py,
# carry the digest of the code they inline and compile anew by themselves)
clean-cache:
	find drs_model tests benchmarks -name '*.nbi' -delete -o -name '*.nbc' -delete

clean: clean-cache
	rm -rf $(VENV) .ros-log .pytest_cache
