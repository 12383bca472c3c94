# Vergence: `make demo` and `make test` set everything up on a fresh Debian machine with Python 3.11.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
PYTEST_ARGS ?= -m "not slow" -n 2

.PHONY: setup demo test test-all test-fresh-seeds bench sweep clean

# When make started (seconds since the epoch): `make setup` says how long it took.
SETUP_START := $(shell date +%s)

setup: $(STAMP)

$(VENV)/bin/python:
	@echo "==> setup: virtual environment $(VENV) ($(PYTHON))"
	$(PYTHON) -m venv $(VENV) || { apt-get update && apt-get install -y python3-venv && $(PYTHON) -m venv --clear $(VENV); }

# Mitsuba's CPU backend (llvm_ad_rgb) loads libLLVM >= 15 at run time; Debian ships it as libllvm15.
# Last, `vergence warm` compiles the commands' Numba kernels into the user's cache
# ($XDG_CACHE_HOME/vergence/numba, else ~/.cache/vergence/numba): first runs then take seconds, not minutes.
$(STAMP): pyproject.toml | $(VENV)/bin/python
	@echo "==> setup: libLLVM >= 15 for Mitsuba"
	@/sbin/ldconfig -p 2>/dev/null | grep -Eq 'libLLVM-(1[5-9]|[2-9][0-9])' || \
	  { echo "libLLVM >= 15 not found: installing Debian's libllvm15 for Mitsuba"; \
	    apt-get update && apt-get install -y libllvm15; }
	@echo "==> setup: pip, then Vergence and its extras (test, web, browser, video, dask)"
	$(PY) -m pip install --progress-bar on --upgrade pip
	$(PY) -m pip install --progress-bar on -e ".[test,web,browser,video,dask]"
	@echo "==> setup: Chromium for the workbench's browser tests"
	@command -v chromium >/dev/null 2>&1 || \
	  { echo "chromium not found: installing Debian's chromium for the workbench's browser tests"; \
	    { apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y chromium; } || \
	    echo "chromium could not be installed: the browser tests will be skipped, with that reason"; }
	@echo "==> setup: compiling the kernels (vergence warm; minutes, once)"
	$(VENV)/bin/vergence warm
	touch $(STAMP)
	@echo "==> setup done in $$(( $$(date +%s) - $(SETUP_START) )) s"

demo: setup
	$(VENV)/bin/vergence demo --out demo-output

test: setup
	$(PY) -m pytest $(PYTEST_ARGS)

test-all: setup
	$(PY) -m pytest -n 2

# The property tests (hypothesis) with a fresh random seed, printed so that a failure can be replayed
# with `--hypothesis-seed=N`; CI runs them derandomized (tests/conftest.py, profile "ci").
ifndef HYPOTHESIS_SEED
HYPOTHESIS_SEED := $(shell od -An -N4 -tu4 /dev/urandom | tr -d ' ')
endif
test-fresh-seeds: setup
	@echo "hypothesis seed: $(HYPOTHESIS_SEED)"
	env -u CI $(PY) -m pytest $(PYTEST_ARGS) -q --hypothesis-seed=$(HYPOTHESIS_SEED) \
	  $$(grep -rlE --include='test_*.py' '^(from|import) hypothesis' tests)

bench: setup
	for f in benchmarks/*.py; do $(PY) $$f || exit 1; done

# The quick hostile-input sweep (tools/sweep): under 5 minutes on 2 cores; report in sweep-output/.
SWEEP_ARGS ?= --quick --jobs 2
sweep: setup
	$(PY) -m tools.sweep --out sweep-output $(SWEEP_ARGS)

clean:
	rm -rf $(VENV) demo-output sweep-output .pytest_cache
