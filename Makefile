# sonolux: plain `make` lists the targets.
SHELL := /bin/bash
VENV  := .venv
PY    := $(VENV)/bin/python
PIP   := $(VENV)/bin/pip
STAMP := $(VENV)/.deps-stamp
PYTHON ?= python3

.DEFAULT_GOAL := help
.PHONY: help venv build test test-rust test-python test-all lint demo bench clean ci web web-deps test-web validation

help: ## list the targets
	@echo "sonolux make targets:"
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk 'BEGIN{FS=":.*## "} {printf "  make %-10s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	@command -v cargo >/dev/null || { echo "error: cargo (Rust) is needed: https://rustup.rs"; exit 1; }
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip
	$(PIP) install --quiet "maturin>=1.9,<2" "numpy>=1.24" "scipy>=1.10" "h5py>=3.8" "trimesh>=4.0" \
	    "soundfile>=0.12" "matplotlib>=3.7" "sofar>=1.1" "netCDF4>=1.6,<1.7.4" "dask>=2024.1" "distributed>=2024.1" "av>=12" "pytest>=8" "ruff>=0.6" \
	    "mypy>=1.10" "hypothesis>=6.100"
	touch $(STAMP)

venv: $(STAMP) ## create .venv and install the Python dependencies

build: $(STAMP) ## build the Rust extension (release) into .venv
	$(VENV)/bin/maturin develop --release --quiet
	@$(PY) -c "import sonolux._core" || { echo "error: the extension did not build"; exit 1; }

test: build test-rust test-python test-web ## build, then run the Rust, Python and viewer tests (fast set)

test-rust: ## cargo tests of the core
	cargo test --release -p sonolux-core --quiet

test-python: build ## pytest, fast set
	$(PY) -m pytest -q

web-deps: ## the viewer's npm packages and Debian's Chromium, installed when missing
	@bash tests/web/run.sh --deps-only

test-web: build ## the viewer's unit tests and browser tests (headless Chromium; installs what is missing)
	@bash tests/web/run.sh

web: ## rebuild the viewer (web/) into python/sonolux/web_dist, which ships it (needs Node.js)
	cd web && { test -x node_modules/.bin/vite || npm install --no-audit --no-fund; } && npm run build

PEERS := pyrato pyroomacoustics mitsuba embreex pyradiance

$(VENV)/.peers-stamp: $(STAMP)
	@echo "installing the peers used by slow checks and benchmarks (not runtime dependencies): $(PEERS)"
	$(PIP) install --quiet $(PEERS)
	touch $@

test-all: build $(VENV)/.peers-stamp test-web ## every test, the slow statistical and peer checks too
	cargo test --release -p sonolux-core --quiet -- --include-ignored
	SONOLUX_HYPOTHESIS=long $(PY) -m pytest -q -m "slow or not slow"

lint: build ## ruff, the binding's stubs against the built module (stubtest), clippy
	$(VENV)/bin/ruff check python tests benchmarks examples
	cd python && ../$(PY) -m mypy.stubtest sonolux._core
	cargo clippy --release --workspace --all-targets --quiet -- -D warnings

ci: test lint ## what .ci/run does

demo: build ## the paper's experiment: three rooms checked, baked, compared (out/demo)
	$(VENV)/bin/sonolux check paper-large
	$(VENV)/bin/sonolux experiment -o out/demo
	$(VENV)/bin/sonolux film out/demo/paper-small.h5 --path examples/walks/paper-small.csv \
	    --fps 12 --size 480x270 -o out/demo/walk-paper-small.mp4

bench: build $(VENV)/.peers-stamp ## benchmarks against peers (Embree, pyroomacoustics, memory bandwidth), results in benchmarks/results
	$(PY) benchmarks/bvh.py
	$(PY) benchmarks/sound.py
	$(PY) benchmarks/mesh_room.py
	$(PY) benchmarks/light.py
	$(PY) benchmarks/radiance.py
	$(PY) benchmarks/auralize.py
	$(PY) benchmarks/dask_bake.py
	$(PY) benchmarks/converge.py
	$(PY) benchmarks/web_bundle.py
	$(PY) benchmarks/compact_field.py
	$(PY) benchmarks/early.py
	$(PY) benchmarks/early.py --scene shoebox
	cargo run --release -p sonolux-core --example wave_bench -- --out benchmarks/results/waves.json

validation: build $(VENV)/.peers-stamp ## measured physics checks, rewrites docs/validation.md
	$(PY) benchmarks/validation.py

clean: ## remove build products, outputs and the virtual environment
	cargo clean
	rm -rf $(VENV) python/sonolux/*.so out
