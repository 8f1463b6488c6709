# The README's two commands: `make demo` and `make test`. Each creates .venv when it is missing
# and installs servolab into it with what it needs, so a fresh machine needs only Python and pip.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

ROS_VENV := .venv-ros
ROS_STAMP := $(ROS_VENV)/.installed
# The real ROS 2 Jazzy rclpy, the tests' oracle for DDS and for servolab.rclpy: from the package
# index, in a venv of its own (it is never servolab's dependency). Where the platform has no
# wheel the install fails, the log says why, and the tests that need it skip saying so.
# rosidl's .msg-to-.idl adapter, parser and type hash generator, with the packages whose type
# descriptions the shipped interfaces use (trajectory_msgs, lifecycle_msgs), hash servolab's
# shipped interface files as a ROS 2 build would (tests/middleware/test_shipped_interfaces.py).
ROS_PACKAGES := ros-jazzy-rclpy ros-jazzy-rmw-fastrtps-cpp ros-jazzy-rmw-dds-common \
	ros-jazzy-std-msgs ros-jazzy-std-srvs ros-jazzy-geometry-msgs ros-jazzy-sensor-msgs \
	ros-jazzy-nav-msgs ros-jazzy-rosgraph-msgs ros-jazzy-test-msgs \
	ros-jazzy-rosidl-adapter ros-jazzy-rosidl-parser ros-jazzy-rosidl-generator-type-description \
	ros-jazzy-trajectory-msgs ros-jazzy-lifecycle-msgs

.PHONY: demo test check lint bench clean ros-oracle view-oracle

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/servolab demo

# Two workers, each test file on one (its module fixtures made once), every realtime test on
# the same worker one after another (tests/scheduling.py): many tests wait on real time (a pty
# at 57142 bps, a subprocess, a stop signal), and every test already keeps to its own
# temporary folder and free ports, and survives a busy CPU. Python writes its bytecode even
# where PYTHONDONTWRITEBYTECODE is set (as on the project's CI machine): the suite starts
# hundreds of servolab processes, and each would otherwise compile every module it imports
# again, and pytest rewrite every test module's asserts again on each run.
# The 25 slowest tests are printed at the end of every run.
PYTEST := env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -q -n 2 --dist loadfile
test: $(STAMP) ros-oracle view-oracle
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(PYTEST) --durations=25

# The inner loop: lint, types and the tests that are neither slow nor realtime (about 2
# minutes on two cores); `make test` runs them all.
check: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(PYTEST) -m "not slow and not realtime" --durations=10

$(ROS_STAMP):
	$(PYTHON) -m venv $(ROS_VENV)
	$(ROS_VENV)/bin/python -m pip install --quiet --retries 1 --timeout 30 $(ROS_PACKAGES) > $(ROS_VENV)/install.log 2>&1 \
		&& touch $(ROS_STAMP) \
		|| echo "make ros-oracle: the real rclpy did not install (see $(ROS_VENV)/install.log);" \
			"the tests that need it will skip"

ros-oracle: $(ROS_STAMP)

# Foxglove's own WebSocket client (@foxglove/ws-protocol) and ROS 2 CDR decoder
# (@foxglove/rosmsg2-serialization), run by Node: the tests' oracle for `servolab view`
# (tests/viewclient.py). npm installs them from the lock file, with a headless Chromium
# shipped inside an npm package (@sparticuz/chromium, driven by puppeteer-core), and esbuild
# bundles the browser page that plots a joint with the same client (page/plot.js ->
# build/plot.bundle.js; tests/robots/test_view_browser.py). Where Node or the registry is
# missing the install fails, the log says why, and the tests that need them skip saying so.
VIEW_CLIENT := tests/view_client
VIEW_STAMP := $(VIEW_CLIENT)/node_modules/.installed

$(VIEW_STAMP): $(VIEW_CLIENT)/package-lock.json $(VIEW_CLIENT)/page/plot.js
	(cd $(VIEW_CLIENT) && npm ci --no-audit --no-fund > install.log 2>&1 \
		&& node_modules/.bin/esbuild page/plot.js --bundle --format=iife \
			--outfile=build/plot.bundle.js --log-level=warning >> install.log 2>&1) \
		&& touch $(VIEW_STAMP) \
		|| echo "make view-oracle: the Foxglove client's npm packages did not install or its page did not bundle" \
			"(see $(VIEW_CLIENT)/install.log); the tests that need them will skip"

view-oracle: $(VIEW_STAMP)

bench: $(STAMP)
	$(BIN)/python benchmarks/bus_cycle.py
	$(BIN)/python benchmarks/middleware.py
	$(BIN)/python benchmarks/wakeups.py
	$(BIN)/python benchmarks/dds.py
	$(BIN)/python benchmarks/view.py
	$(BIN)/python benchmarks/sim.py

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy

clean:
	rm -rf $(VENV) $(ROS_VENV) tests/view_client/node_modules tests/view_client/build build *.egg-info src/*.egg-info .pytest_cache .mypy_cache
