# The README's two commands: `make demo` and `make test`. Each creates .venv when it is missing
# and installs servolab into it with what it needs, so a fresh machine needs only Python and pip.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/servolab demo

# Two workers, each test file on one (its module fixtures made once): many tests wait on
# real time (a pty at 57142 bps, a subprocess, a stop signal), and every test already keeps
# to its own temporary folder and free ports, and survives a busy CPU.
test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/python -m pytest -q -n 2 --dist loadfile

bench: $(STAMP)
	$(BIN)/python benchmarks/bus_cycle.py
	$(BIN)/python benchmarks/middleware.py
	$(BIN)/python benchmarks/sim.py

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy

clean:
	rm -rf $(VENV) build *.egg-info src/*.egg-info .pytest_cache .mypy_cache
