# Unbound: build, test, demo. Everything installs itself into .venv (Python 3.11).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
WHEEL_GLOB := dist/unbound_core-*-cp311-abi3-*.whl
NATIVE_SOURCES := $(wildcard native/src/*.c native/src/*.h native/unbound_core/*.py) native/setup.py native/pyproject.toml

.PHONY: venv wheel test test-native bench demo clean

venv: $(VENV)/.stamp
$(VENV)/.stamp: requirements-dev.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -r requirements-dev.txt
	touch $@

# The abi3 wheel of the native core (one per platform, every Python >= 3.11).
wheel: $(VENV)/.stamp dist/.wheel-stamp
dist/.wheel-stamp: $(NATIVE_SOURCES)
	rm -rf dist/unbound_core-*.whl native/build native/*.egg-info
	$(PY) -m pip wheel -q --no-deps --no-build-isolation -w dist ./native
	rm -rf native/build native/*.egg-info
	$(PY) -m pip install -q --force-reinstall --no-deps $(WHEEL_GLOB)
	touch $@

test: wheel
	$(PY) -m pytest tests

test-native: wheel
	$(PY) -m pytest tests/native

bench: wheel
	$(PY) bench/bench_core.py

demo: wheel
	$(PY) examples/native_demo.py

clean:
	rm -rf dist native/build native/*.egg-info native/unbound_core/*.so
