# Vergence: `make demo` and `make test` set everything up on a fresh Debian machine with Python 3.11.
PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
PYTEST_ARGS ?= -m "not slow" -n 2

.PHONY: setup demo test test-all test-fresh-seeds bench sweep clean

setup: $(STAMP)

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV) || { apt-get update && apt-get install -y python3-venv && $(PYTHON) -m venv --clear $(VENV); }

# Mitsuba's CPU backend (llvm_ad_rgb) loads libLLVM >= 15 at run time; Debian ships it as libllvm15.
$(STAMP): pyproject.toml | $(VENV)/bin/python
	@/sbin/ldconfig -p 2>/dev/null | grep -Eq 'libLLVM-(1[5-9]|[2-9][0-9])' || \
	  { echo "libLLVM >= 15 not found: installing Debian's libllvm15 for Mitsuba"; \
	    apt-get update && apt-get install -y libllvm15; }
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test,web,browser,video,dask]"
	@command -v chromium >/dev/null 2>&1 || \
	  { echo "chromium not found: installing Debian's chromium for the workbench's browser tests"; \
	    { apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y chromium; } || \
	    echo "chromium could not be installed: the browser tests will be skipped, with that reason"; }
	touch $(STAMP)

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
