# uavbus top-level build.
#
#   make demo    the main job (installs what it needs first)
#   make test    every test (installs what it needs first)
#   make setup   idempotent install: Debian packages + .venv with the uavbus package
#
# Everything below installs only from Debian and PyPI; nothing is downloaded at run time.

SHELL       := /bin/bash
PYTHON      ?= python3
VENV        := .venv
VPY         := $(VENV)/bin/python
BUILD       := build
BUILD_ASAN  := build-asan
APT_PKGS    := libcmocka-dev cmake ninja-build pkg-config libsodium-dev gcc-arm-none-eabi libnewlib-arm-none-eabi g++
SETUP_STAMP := $(VENV)/.uavbus-setup-stamp

.PHONY: setup test test-c test-py demo bench clean apt-deps

setup: apt-deps $(SETUP_STAMP)

# Installs only the Debian packages that are missing; does nothing when all are present.
apt-deps:
	@missing=""; for p in $(APT_PKGS); do \
	  dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "setup: installing Debian packages:$$missing"; \
	  SUDO=""; [ "$$(id -u)" = 0 ] || SUDO=sudo; \
	  $$SUDO apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing >/dev/null; \
	fi

# The stamp depends on everything that changes what pip installs, the cffi extension (uavbus._ub,
# compiled from the runtime_c sources) included, so Python never tests a stale build of the C runtime.
FFI_INPUTS := $(wildcard runtime_c/src/*.c runtime_c/src/*.h runtime_c/include/ub/*.h \
                runtime_py/uavbus/_cdefs/*.h) runtime_py/uavbus/_build_ffi.py
$(SETUP_STAMP): pyproject.toml setup.py $(FFI_INPUTS)
	@test -x $(VPY) || $(PYTHON) -m venv $(VENV)
	$(VPY) -m pip install -q --upgrade pip setuptools wheel
	$(VPY) -m pip install -q -e '.[test,demo]'
	@touch $@

# C runtime + generated-code tests, plain and under ASan/UBSan.
test-c: setup
	cmake -S . -B $(BUILD) -G Ninja -DUAVBUS_PYTHON=$(abspath $(VPY)) >/dev/null
	cmake --build $(BUILD)
	ctest --test-dir $(BUILD) --output-on-failure
	cmake -S . -B $(BUILD_ASAN) -G Ninja -DUAVBUS_PYTHON=$(abspath $(VPY)) -DUAVBUS_SANITIZE=ON >/dev/null
	cmake --build $(BUILD_ASAN)
	ctest --test-dir $(BUILD_ASAN) --output-on-failure

test-py: setup
	$(VPY) -m pytest -q tests

test: test-c test-py

# The paper's HITL and Table 1 scenarios end to end (examples/demo/hitl_demo.py). The CMake build
# generates the flightsw catalogue through uavbus_generate() and builds the C node program.
demo: setup
	cmake -S . -B $(BUILD) -G Ninja -DUAVBUS_PYTHON=$(abspath $(VPY)) >/dev/null
	cmake --build $(BUILD) --target uavbus_node
	$(VPY) examples/demo/hitl_demo.py --out demo-out --program $(BUILD)/examples/node/uavbus_node

# Measurements, not tests: optimised build of the tools, results in bench/results.md.
bench: setup
	bench/run.sh

clean:
	rm -rf $(BUILD) $(BUILD_ASAN) build-bench build-mcu demo-out
