# sonolux: plain `make` lists the targets.
SHELL := /bin/bash
VENV  := .venv
PY    := $(VENV)/bin/python
PIP   := $(VENV)/bin/pip
STAMP := $(VENV)/.deps-stamp
PYTHON ?= python3

.DEFAULT_GOAL := help
.PHONY: help venv build test test-rust test-python test-all lint demo bench clean ci

help: ## list the targets
	@echo "sonolux make targets:"
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN{FS=":.*## "} {printf "  make %-10s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	@command -v cargo >/dev/null || { echo "error: cargo (Rust) is needed: https://rustup.rs"; exit 1; }
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip
	$(PIP) install --quiet "maturin>=1.9,<2" "numpy>=1.24" "scipy>=1.10" "h5py>=3.8" "trimesh>=4.0" \
	    "soundfile>=0.12" "matplotlib>=3.7" "pytest>=8" "ruff>=0.6"
	touch $(STAMP)

venv: $(STAMP) ## create .venv and install the Python dependencies

build: $(STAMP) ## build the Rust extension (release) into .venv
	$(VENV)/bin/maturin develop --release --quiet
	@$(PY) -c "import sonolux._core" || { echo "error: the extension did not build"; exit 1; }

test: build test-rust test-python ## build, then run the Rust and Python tests (fast set)

test-rust: ## cargo tests of the core
	cargo test --release -p sonolux-core --quiet

test-python: build ## pytest, fast set
	$(PY) -m pytest -q

test-all: build test-rust ## every test, the slow statistical and peer checks too
	$(PY) -m pytest -q -m "slow or not slow"

lint: $(STAMP) ## ruff and clippy
	$(VENV)/bin/ruff check python tests benchmarks
	cargo clippy --release --workspace --quiet -- -D warnings

ci: test lint ## what .ci/run does

demo: build ## the main job on built-in data
	$(VENV)/bin/sonolux check paper-small
	$(VENV)/bin/sonolux check paper-medium
	$(VENV)/bin/sonolux check paper-large

bench: build ## benchmarks against peers (installs the peers into .venv)
	$(PY) benchmarks/bvh.py

clean: ## remove build products and the virtual environment
	cargo clean
	rm -rf $(VENV) python/sonolux/*.so
