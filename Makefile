# subsurf — build, test, demo, bench. Every target sets itself up on a fresh machine.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
export VIRTUAL_ENV := $(abspath $(VENV))
export PATH := $(abspath $(VENV))/bin:$(PATH)

.PHONY: all venv build lint test test-rust-compile test-rust-then-docs test-docs-check test-pytest test-pytest-render test-pytest-cli test-pytest-rest test-fast test-rust test-rust-fast test-python test-python-fast demo figures bench clean docs docs-check dist dist-check

all: build

$(VENV)/.ready: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "maturin>=1.5,<2" "numpy>=1.22" "matplotlib>=3.5" "h5py>=3.6" "pytest>=7" "scipy>=1.8" \
		"hypothesis>=6.100" "ruff==0.17.6" "trimesh>=4" "openexr>=3.3" "dask[distributed]>=2023.1" \
		"sphinx>=7.2" "myst-parser>=3" "sphinx-gallery>=0.17" "furo>=2024.1"  # the test, render, cluster and docs extras
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
# Clippy and rustdoc check in a target directory of their own (target/lint): their artifacts are not
# the build's anyway, and `make test` runs them beside the release build of the tests instead of
# queueing on its lock.
LINT_CARGO := CARGO_TARGET_DIR=$(abspath target/lint) cargo
lint: venv
	cargo fmt --all --check
	$(LINT_CARGO) clippy --workspace --all-targets -q -- -D warnings
	RUSTDOCFLAGS="-D warnings" $(LINT_CARGO) doc --workspace --no-deps -q
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

# Two jobs at a time where they do not depend on each other: the venv's installs, clippy, the
# release build of the core's tests and the extension's build overlap on 2 cores; then the core's
# tests and the docs check beside pytest in three parts (each mostly one thread; the command-line
# and cluster part waits on child processes, timeouts and signals much of its time), so that the
# four fill both cores: the renderer's tests (with the first-hour and docs-script runs), the
# command line and the cluster, and the rest.
test:
	$(MAKE) --no-print-directory -j2 lint test-rust-compile build
	$(MAKE) --no-print-directory -j4 test-rust-then-docs test-pytest-render test-pytest-cli test-pytest-rest

# The core's tests compiled beside the lints and the build, run beside pytest (mostly one thread).
test-rust-compile:
	$(CARGO_TEST) --no-run

test-rust-then-docs:
	$(CARGO_TEST)
	$(DOCS_CHECK)

test-docs-check:
	$(DOCS_CHECK)

test-pytest:
	$(PY) -m pytest -q tests

# The parts of `make test`'s pytest run: every file is in exactly one (the rest takes what the
# other parts do not name, so a new test file is never left out).
PYTEST_RENDER := $(sort $(wildcard tests/test_render*.py)) tests/test_adaptive.py tests/test_first_hour.py \
	tests/test_docs_scripts.py
PYTEST_CLI := $(sort $(wildcard tests/test_cli*.py)) tests/test_cluster.py tests/test_properties.py
test-pytest-render:
	$(PY) -m pytest -q $(PYTEST_RENDER)

test-pytest-cli:
	$(PY) -m pytest -q $(PYTEST_CLI)

test-pytest-rest:
	$(PY) -m pytest -q tests $(PYTEST_RENDER:%=--ignore=%) $(PYTEST_CLI:%=--ignore=%)

# The two tiers side by side (the core's tests use both cores for 12 s, pytest mostly one for 40 s).
test-fast:
	$(MAKE) --no-print-directory -j2 test-rust-fast test-python-fast

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

# The documentation site (docs/building.md): docs/_build/html/index.html. -W: a warning is an error.
SPHINX := $(PY) -m sphinx -W --keep-going -q -b html
docs: build
	$(SPHINX) -d docs/_build/doctrees docs docs/_build/html
	@echo "site: docs/_build/html/index.html"

# What `make test` runs: every guide and API page read afresh (-E), the check that each public name
# has an entry, and one gallery script run, built apart from the full site.
docs-check: build
	$(DOCS_CHECK)
DOCS_CHECK = SUBSURF_DOCS_GALLERY=plot_brdf_lobes $(SPHINX) -E -d docs/_build/check-doctrees docs docs/_build/check

# An abi3 manylinux wheel and an sdist in dist/ (docs/building.md). ZIG=1 (default): linked by zig
# (the ziglang package) for manylinux2014 (glibc >= 2.17); its own target dir, so the first build
# compiles everything (~8 min on the shared 2 cores), later ones seconds. ZIG=0: linked natively,
# reusing `make build`'s target/release (seconds), tagged with the glibc the binary needs
# (manylinux_2_34 here). dist-check installs the wheel into a fresh venv outside the tree and runs
# `subsurf demo --quick` there (tests/check_dist.py; about 1.5 min, not part of `make test`).
ZIG ?= 1
dist: venv
	rm -rf dist
ifeq ($(ZIG),1)
	$(PY) -m pip install -q "ziglang>=0.13"
	$(VENV)/bin/maturin build --release --zig --compatibility manylinux2014 -o dist
else
	$(VENV)/bin/maturin build --release -o dist
endif
	$(VENV)/bin/maturin sdist -o dist

dist-check: dist
	$(PY) tests/check_dist.py dist

clean:
	rm -rf target $(VENV) dist docs/_build docs/api docs/gallery docs/gallery-check
