# Two commands matter: `make demo` (the main job) and `make test` (every test).
# Everything else is a building block they call.
VENV   := .venv
PY     := $(VENV)/bin/python
PYTEST_ARGS ?=

.PHONY: env demo test test-fast firmware simboard core-tests protocol clean help

help:
	@echo "make demo   - identify, quantize, flash and verify a simulated actuator (emulator)"
	@echo "make test   - run every test (unit, property, fuzz, firmware-on-host, simboard, slow, bench)"
	@echo "make env    - create .venv and install Debian/Python dependencies (idempotent)"
	@echo "make firmware - build the Uno ELF/HEX offline with gcc-avr"

env:
	@tools/bootstrap.sh

protocol: env
	$(PY) protocol/generate.py

firmware: env
	$(MAKE) -C firmware

simboard: env
	$(MAKE) -C tools/simboard

DEMO_ARGS ?=
demo: env
	$(VENV)/bin/porosense demo $(DEMO_ARGS)

# The full suite: default tests, slow tests (with CI-sized parameters) and benchmarks.
test: env
	@if [ -f firmware/Makefile ]; then $(MAKE) -s -C firmware; fi
	@if [ -f tools/simboard/Makefile ]; then $(MAKE) -s -C tools/simboard; fi
	$(PY) -m pytest $(PYTEST_ARGS)

# Only the quick tests (no slow marker), for the edit-run loop.
test-fast: env
	$(PY) -m pytest -m "not slow" $(PYTEST_ARGS)

clean:
	rm -rf firmware/build tools/simboard/build tests/core/build .pytest_cache
