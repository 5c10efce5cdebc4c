# subsurf — build, test, demo, bench. Every target sets itself up on a fresh machine.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
export VIRTUAL_ENV := $(abspath $(VENV))
export PATH := $(abspath $(VENV))/bin:$(PATH)

.PHONY: all venv build lint test test-fast test-rust test-rust-fast test-python test-python-fast demo bench clean

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

# The core's tests run in the release profile of the extension build (`make build`), with the same
# dependency features (subsurf-py has no Rust tests, so `--workspace` resolves them as maturin does):
# dependencies and subsurf-core are compiled once for both, with no debug info. `--tests` (the targets
# with `test = true`: not subsurf-py, whose build would change with maturin's PYO3_CONFIG_FILE): the
# examples are compiled by clippy, and the crates have no doctests.
CARGO_TEST := cargo test --release --workspace --tests -q

# Two tiers. `make test-fast` (the inner loop, about a minute after a build): the core's tests but
# those named `*_slow`, and pytest without `@pytest.mark.slow`. `make test`: lints and every test.
test-rust:
	$(CARGO_TEST)

test-rust-fast:
	$(CARGO_TEST) -- --skip _slow

test-python: build
	$(PY) -m pytest -q tests

test-python-fast: build
	$(PY) -m pytest -q -m "not slow" tests

# Formatting and lints: rustfmt.toml and [tool.ruff] in pyproject.toml settle the style (width 120).
lint: venv
	cargo fmt --all --check
	cargo clippy --workspace --all-targets -q -- -D warnings
	RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps -q
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

test: lint test-rust test-python

test-fast: test-rust-fast test-python-fast

demo: build
	$(VENV)/bin/subsurf demo

bench: build
	$(PY) benches/bench.py
	$(PY) benches/render_bench.py
	$(PY) benches/bench_profiles.py
	$(PY) benches/bench_cluster.py

clean:
	rm -rf target $(VENV)
