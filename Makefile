# Thin wrapper: every target sets up .venv itself (python3 and make are all it needs).
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
export JAX_PLATFORMS ?= cpu
export MPLBACKEND ?= Agg
BEFORE  ?= 0e7885f
SUDO    := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: run test test-slow lint bench atmospheres surfaces library lamp-models ler \
        g cct sweep compare classify classify-partitions radiometry spatial \
        noise-aware estimate study estimate-moon estimate-library external-tm30 unseen-ceiling robustness judge \
        before-after report check-report docs tutorial clean help

help:  ## list the targets and what they do
	@grep -E '^[a-zA-Z0-9_.-]+:.*## ' $(MAKEFILE_LIST) | sed -E 's/^([^:]+):[^#]*## /\1: /'

$(STAMP): pyproject.toml requirements.lock
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade 'pip>=24,<27'
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test]'
	touch $@

run: $(STAMP)  ## set up, then the default band search + comparison with reference sensors (writes recommendation.json "spectral"); on perturbed scenes: ARGS="--preset search_perturbed --out results/search_perturbed"
	$(BIN)/python -m experiments.search run $(ARGS)

test: $(STAMP)  ## set up, then the fast test suite (no 6S, no long sweeps, no Monte Carlo)
	$(BIN)/python -m pytest -q

test-slow: $(STAMP)  ## the tests marked slow (6S runs, Monte Carlo renders)
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test,atmos,render]'
	$(BIN)/python -m pytest -q -m slow

lint: $(STAMP)
	$(BIN)/ruff check .

bench: $(STAMP)  ## benchmarks; ratios against baselines of the same run in results/bench/
	$(BIN)/python -m experiments.bench_photometry
	$(BIN)/python -m experiments.bench_forward
	$(BIN)/python -m experiments.bench_search
	$(BIN)/python -m experiments.bench_spatial
	$(BIN)/python -m experiments.bench_inversion
	$(BIN)/python -m experiments.bench_cli

atmospheres: $(STAMP)  ## regenerate the 6S tables (25-50 min on 2 cores; never in make test)
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test,atmos]' || true
	$(BIN)/python -m bandopt.datasets._atmosphere_build --check
	$(BIN)/python -m bandopt.datasets._atmosphere_build

surfaces: $(STAMP)  ## check the vendored earthlib extract against earthlib
	$(BIN)/python -m bandopt.datasets._surfaces_build --check

library: $(STAMP)
	mkdir -p results/library
	$(BIN)/bandopt library --plot results/library/lamps.png --json > results/library/library.json
	$(BIN)/bandopt library --counts --json > results/library/counts.json

lamp-models: $(STAMP)  ## physical lamp models: fits + leave-one-lamp-out validation (~1 h)
	$(BIN)/python -m experiments.lamp_models

ler: $(STAMP)
	$(BIN)/python -m experiments.search ler
g: $(STAMP)
	$(BIN)/python -m experiments.search g
cct: $(STAMP)
	$(BIN)/python -m experiments.search cct
sweep: $(STAMP)  ## all targets, n = 1..6 (+ pan)
	$(BIN)/python -m experiments.search sweep
compare: $(STAMP)
	$(BIN)/python -m experiments.search compare
noise-aware: $(STAMP)
	$(BIN)/python -m experiments.noise_aware

estimate: $(STAMP)  ## inversion vs regression on held-out and unseen lamps, and the estimators with 5 modelled lamps per rare class in training (writes recommendation.json "estimation")
	$(BIN)/python -m experiments.estimate --modelled-per-class 5

study: $(STAMP)  ## one study of the estimator by name: NAME=estimate-planck (resumable: ARGS=--resume); without NAME, list them (bandopt.studies.STUDIES)
	$(BIN)/python -m experiments.study $(NAME) $(ARGS)

estimate-moon: $(STAMP)  ## the estimate's scenes split by Moon state: where the G error comes from (about 10 min)
	$(BIN)/python -m experiments.estimate_moon

estimate-library: $(STAMP)  ## what a lamp the library lacks costs: bandopt evaluate's estimator on held-out lamps and on lamps its prior holds, the same lamps paired, our bands and the two best reference sensors; surface knowledge; library size; 4 lamp partitions (resumable: ARGS=--resume)
	$(BIN)/python -m experiments.estimate_library $(ARGS)

external-tm30: $(STAMP)  ## external check: bandopt evaluate, as a user runs it, on the 210 measured IES TM-30-15 lamps the library has never seen, our bands and the two best reference sensors; and told the surface, the inversion against --estimator direct with 26 contiguous bands (about 3 min)
	$(BIN)/python -m experiments.external_tm30 $(ARGS)

unseen-ceiling: $(STAMP)  ## the level-1 family of unseen lamp types from bare lamp spectra (5-50 nm) and the recommended bands, classifiers trained on the other classes: the ceiling of issue 12's 90 % goal (under a minute)
	$(BIN)/python -m experiments.unseen_ceiling $(ARGS)

robustness: $(STAMP)  ## the shipped estimate on held-out lamps under measurement effects (background, noise, slit, shift, truncation, mixtures, a type left out of the prior), paired with the clean rows, our bands and SDGSAT-1 and Nightsat, 4 lamp partitions -> results/robustness (resumable: ARGS=--resume; ARGS=--quick for a short run; ARGS="--config tolerance": our bands' filter tolerances under the shipped estimator -> results/robustness/tolerance)
	nice $(BIN)/python -m experiments.robustness $(ARGS)

judge: $(STAMP)  ## the search's candidate designs and the reference sensors judged by the shipped estimator on clean and perturbed held-out lamps, 4 lamp partitions; the choice by the one-SD rule -> results/judge (resumable: ARGS=--resume)
	nice $(BIN)/python -m experiments.judge $(ARGS)

classify: $(STAMP)  ## lamp-type classification (writes recommendation.json "classification")
	$(BIN)/python -m experiments.classify
	$(BIN)/python -m experiments.readme_sections classification

classify-partitions: $(STAMP)  ## fixed designs (both recommendations, every reference sensor) over 4 lamp partitions: KNN, KNN + modelled lamps, inversion; mean +/- SD and paired differences (results/classify_partitions); recomputed from scratch (resume an interrupted run with python -m experiments.classify_partitions)
	$(BIN)/python -m experiments.classify_partitions --fresh

radiometry: $(STAMP)  ## detection limits, saturation, bit depth (writes recommendation.json "radiometry")
	$(BIN)/python -m experiments.radiometry

spatial: $(STAMP)  ## GSD needed, overlapping lamp types (writes recommendation.json "spatial")
	$(BIN)/python -m experiments.spatial
	$(BIN)/python -m experiments.spatial_overlap
	$(BIN)/python -m experiments.readme_sections spatial

before-after: $(STAMP)  ## headline numbers at git BEFORE (default 0e7885f) vs the working tree (writes results/before_after.json + README section)
	$(BIN)/python -m experiments.before_after --before $(BEFORE)

report: $(STAMP)  ## results/report/index.html from results/ only (fails if two results files disagree)
	$(BIN)/bandopt report --out results/report

check-report: report  ## open the report in headless Chromium: figures load, tables have rows, screenshot
	command -v chromium >/dev/null && command -v chromedriver >/dev/null || \
	  { $(SUDO) apt-get update -q && DEBIAN_FRONTEND=noninteractive $(SUDO) \
	    apt-get install -y -q chromium chromium-driver; }
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test,browser]'
	$(BIN)/python -m experiments.check_report --report results/report/index.html \
	  --screenshot results/report/screenshot.png

docs: $(STAMP)  ## user guide + API reference from the docstrings (Sphinx, offline) -> docs/_build/html
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test,docs]'
	$(BIN)/python -m sphinx -b html -q -W --keep-going -E docs docs/_build/html
	@echo "open docs/_build/html/index.html"

tutorial: $(STAMP)  ## the worked tutorial of docs/tutorial.rst (own lamp spectra, 3 sensors, the report)
	$(BIN)/python -m experiments.tutorial --out tutorial-output

clean:
	rm -rf $(VENV) .pytest_cache
