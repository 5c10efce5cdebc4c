# subsurf — build, test, demo, bench. Every target sets itself up on a fresh machine.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
export VIRTUAL_ENV := $(abspath $(VENV))
export PATH := $(abspath $(VENV))/bin:$(PATH)

.PHONY: all venv build lint test test-rust test-python demo figures bench clean

all: build

$(VENV)/.ready: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "maturin>=1.5,<2" "numpy>=1.22" "matplotlib>=3.5" "h5py>=3.6" "pytest>=7" "scipy>=1.8" "hypothesis>=6.100" "ruff==0.17.6" "trimesh>=4" "openexr>=3.3" "dask[distributed]>=2023.1"
	touch $@

venv: $(VENV)/.ready

# Build the extension (release) and install the package in development mode into the venv.
build: venv
	$(VENV)/bin/maturin develop --release -q

test-rust:
	cargo test --workspace --exclude subsurf-py -q

test-python: build
	$(PY) -m pytest -q tests

# Formatting and lints: rustfmt.toml and [tool.ruff] in pyproject.toml settle the style (width 120).
lint: venv
	cargo fmt --all --check
	cargo clippy --workspace --all-targets -q -- -D warnings
	RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps -q
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

test: lint test-rust test-python

demo: build
	$(VENV)/bin/subsurf demo

# Regenerate README/docs figures and the validation table (slow; not part of `make test`, which runs
# docs/scripts/figures.py --quick through tests/test_docs_scripts.py).
figures: build
	$(PY) docs/scripts/figures.py

bench: build
	$(PY) benches/bench.py
	$(PY) benches/render_bench.py
	$(PY) benches/bench_profiles.py
	$(PY) benches/bench_cluster.py

clean:
	rm -rf target $(VENV)
