# Two entry points for a fresh machine with Python 3.11+ (see README):
#   make validate   install, then run the cross-validation report (`visviva validate`)
#   make test       install, then lint and run the test suite
# The environment is .venv, created by uv from the lockfile uv.lock (uv is installed with pip
# when it is not on PATH). Bytecode is compiled at install time (uv does not by default, and with
# PYTHONDONTWRITEBYTECODE set Python never writes it): without it every process recompiles
# numba, scipy and astropy from source, about 1 s more for the first call of visviva.

PYTHON ?= python3
UV := $(shell command -v uv 2>/dev/null)
ifeq ($(UV),)
UV := $(PYTHON) -m uv
endif

.PHONY: install validate test test-slow lint bench docs clean

.venv/.installed: pyproject.toml uv.lock
	@command -v uv >/dev/null 2>&1 || $(PYTHON) -m uv --version >/dev/null 2>&1 || $(PYTHON) -m pip install --quiet uv
	$(UV) sync --frozen --all-extras --compile-bytecode
	$(UV) run --frozen --no-sync python -m compileall -q src
	@touch $@

install: .venv/.installed

validate: install
	$(UV) run --frozen --no-sync visviva validate

lint: install
	$(UV) run --frozen --no-sync ruff check .
	$(UV) run --frozen --no-sync lint-imports

# the tests run on every core (pytest-xdist, at most 4 processes; each test file in one process,
# so a file's tests keep their order): on CI's two cores most tests are single-threaded Python
# and numba compilation, which left the second core idle
test: lint docs
	$(UV) run --frozen --no-sync pytest -n auto --maxprocesses=4 --dist loadfile --durations=20

# the documentation site; warnings fail the build, docstring markup problems included
# (VISVIVA_DOCS_STRICT=1; see docs/conf.py)
docs: install
	VISVIVA_DOCS_STRICT=1 $(UV) run --frozen --no-sync sphinx-build -W --keep-going -q -b html docs docs/_build/html

test-slow: install
	$(UV) run --frozen --no-sync pytest -n auto --maxprocesses=4 --dist loadfile -m "slow or live"

bench: install
	$(UV) run --frozen --no-sync python -m benchmarks

clean:
	rm -rf .venv .pytest_cache .ruff_cache
