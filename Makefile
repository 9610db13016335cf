# Thin wrapper: every target sets up .venv itself (python3 and make are all it needs).
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
export JAX_ENABLE_X64 ?= 1
export MPLBACKEND ?= Agg

.PHONY: run test test-slow lint bench atmospheres library clean

$(STAMP): pyproject.toml requirements.lock
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade 'pip>=24,<27'
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test]'
	touch $@

run: $(STAMP)  ## set up and run the main job on the built-in data
	$(BIN)/bandopt library --counts

test: $(STAMP)  ## set up and run the fast test suite
	$(BIN)/python -m pytest -q

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

lint: $(STAMP)
	$(BIN)/ruff check .

bench: $(STAMP)  ## benchmarks; ratios written to results/bench/
	$(BIN)/python -m experiments.bench_photometry

atmospheres: $(STAMP)  ## regenerate the 6S transmittance tables (not part of `make test`)
	$(BIN)/python -m bandopt.datasets._atmosphere_build --check
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test,atmos]'
	$(BIN)/python -m bandopt.datasets._atmosphere_build

library: $(STAMP)
	$(BIN)/bandopt library --plot results/library/lamps.png --json > results/library/library.json

clean:
	rm -rf $(VENV) .pytest_cache
