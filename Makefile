# Unbound: build, test, demo. Everything installs itself into .venv.
# bpy has wheels for one Python each: python3.11 -> bpy 4.2 LTS, else python3.13 -> bpy 5.2
# (requirements-dev.txt pins both by python_version); with neither, tools/check_system.sh says what
# to install (and installs it as root with apt-get). Override: make PYTHON=/path/to/python3.13
PYTHON ?= $(shell command -v python3.11 || command -v python3.13)
VENV := .venv
PY := $(VENV)/bin/python
WHEEL_GLOB := dist/unbound_core-*-cp311-abi3-*.whl
NATIVE_SOURCES := $(wildcard native/src/*.c native/src/*.h native/unbound_core/*.py) native/setup.py native/pyproject.toml

.PHONY: venv wheel extension test test-native bench bench-viewport demo gallery sanitize fuzz fuzz-ci clean \
	dist check-binaries test-platforms

venv: $(VENV)/.stamp
# tools/check_system.sh first: the Python, its venv and headers, a C compiler and the X11/GL
# libraries bpy loads (installed with apt-get as root; otherwise it prints the command and stops).
$(VENV)/.stamp: requirements-dev.txt tools/check_system.sh
	py=$$(sh tools/check_system.sh $(PYTHON)) && "$$py" -m venv $(VENV)
	$(PY) -m pip install -q pip==$$(sed -n 's/^pip==//p' requirements-dev.txt)
	$(PY) -m pip install -q -r requirements-dev.txt
	touch $@

# The abi3 wheel of the native core (one per platform, every Python >= 3.11).
wheel: $(VENV)/.stamp dist/.wheel-stamp
dist/.wheel-stamp: $(VENV)/.stamp $(NATIVE_SOURCES)
	rm -rf dist/unbound_core-*.whl native/build native/*.egg-info
	$(PY) -m pip wheel -q --no-deps --no-build-isolation -w dist ./native
	rm -rf native/build native/*.egg-info build/wheel
	# Unpacked for the native tests; deliberately not installed into .venv, so that bpy finds
	# the core only through the installed extension, as a user's Blender does.
	$(PY) -m zipfile -e $(WHEEL_GLOB) build/wheel
	touch $@

# The Blender extension zip: addon/ + manifest + wheel, built and validated by Blender's tool.
extension: dist/.extension-stamp
dist/.extension-stamp: dist/.wheel-stamp blender_manifest.toml $(shell find addon -name '*.py') tools/build_extension.py
	$(PY) tools/build_extension.py
	touch $@

# Every platform Blender runs on (tools/cross_build.py): one wheel per platform cross-compiled by
# zig (Windows x64/arm64, macOS arm64/x64, Linux x64/arm64 for glibc >= 2.17), byte-reproducible,
# and one extension zip per platform built and validated by Blender's tool, in dist/release/.
# Cold machine: about 6 min (zig builds its C libraries once into build/zig-cache); then seconds.
DIST_STAMP := dist/release/.stamp
$(VENV)/.dist-stamp: $(VENV)/.stamp requirements-dist.txt
	$(PY) -m pip install -q -r requirements-dist.txt
	touch $@
$(DIST_STAMP): $(VENV)/.dist-stamp $(NATIVE_SOURCES) tools/cross_build.py tools/build_extension.py blender_manifest.toml $(shell find addon -name '*.py')
	$(PY) tools/cross_build.py
	$(PY) tools/build_extension.py --release
	touch $@
dist: $(DIST_STAMP)

# Static checks of the six binaries (architecture, minimum OS, libraries, stable ABI, signature).
check-binaries: $(DIST_STAMP)
	$(PY) tools/check_binaries.py

# The release builds on other platforms, run here: linux-arm64 under qemu-user, windows-x64 under
# wine in the official Windows CPython; their render digests equal x86-64 Linux's; the linux-x64
# release zip installed and rendering in bpy 4.2 and in Python 3.13 / bpy 5.2; the farm set-up.
test-platforms: $(DIST_STAMP) extension
	UNBOUND_PLATFORM_TESTS=1 $(PY) -m pytest tests/platforms --durations=10

# --durations: the slowest tests, printed at the end (CI has 90 minutes for all of .ci/run).
test: extension
	$(PY) -m pytest tests --durations=25

test-native: wheel
	$(PY) -m pytest tests/native

bench: wheel
	$(PY) bench/bench_core.py

# The Rendered viewport: time from a parameter change to the first image and to full refinement.
bench-viewport: extension
	$(PY) bench/bench_viewport.py

# The main job: a keyframed mu animation rendered through Blender's pipeline (bpy 4.2) with the
# built extension installed by Blender's installer into a private user directory.
# A fresh user directory each time: Blender's installer keeps an already installed wheel of the
# same name and version, which would leave an older native core in place.
demo: extension
	rm -rf build/blender-user
	mkdir -p build/blender-user/config
	BLENDER_USER_RESOURCES=$(CURDIR)/build/blender-user $(PY) examples/animate_mu.py --out $(CURDIR)/out/animate_mu

# Optional: one PNG per bundled fractal preset (docs/gallery/, shown in the README), rendered like
# the demo but in a fresh user directory each time: Blender's installer keeps an installed wheel
# of the same name and version, so a reused directory can hold an older native core.
gallery: extension
	rm -rf build/gallery-user
	mkdir -p build/gallery-user/config
	BLENDER_USER_RESOURCES=$(CURDIR)/build/gallery-user $(PY) examples/gallery.py --out $(CURDIR)/docs/gallery

# Reliability (tools/sanitize.sh): the native tests against an ASan + UBSan build with leaks checked
# at exit; the coverage-guided fuzzer over the native API, bounded for CI (FUZZ_SECONDS) or the long
# campaign (FUZZ_RUNS inputs). A crash stops the fuzzer and leaves its input in build/fuzz/.
FUZZ_SECONDS ?= 180
FUZZ_RUNS ?= 100000
SANITIZED := build/sanitize/unbound_core/_native.abi3.so
$(SANITIZED): $(VENV)/.stamp $(NATIVE_SOURCES) tools/sanitize.sh
	sh tools/sanitize.sh build

sanitize: $(SANITIZED)
	sh tools/sanitize.sh test

fuzz-ci: $(SANITIZED)
	sh tools/sanitize.sh fuzz -max_total_time=$(FUZZ_SECONDS) -max_len=2048 -print_final_stats=1

fuzz: $(SANITIZED)
	sh tools/sanitize.sh fuzz -runs=$(FUZZ_RUNS) -max_len=2048 -print_final_stats=1

clean:
	rm -rf dist native/build native/*.egg-info native/unbound_core/*.so build/cross
