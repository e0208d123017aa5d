# kinsync: two-command set-up. `make demo` and `make test` install what they need first.
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
PYTHON  ?= python3

.PHONY: install demo test lint typecheck unit bench clean clean-numba test-min

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[all,dev]"
	touch $(STAMP)

demo: install
	$(BIN)/kinsync demo

lint: install
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks

typecheck: install
	$(BIN)/mypy

unit: install
	$(BIN)/pytest -n 2 --dist loadfile

test: lint typecheck unit

bench: install
	@for f in benchmarks/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

# The oldest versions pyproject.toml allows (.ci/min-versions.txt) in a venv of their own,
# on the whole suite and the demo: run by hand after changing a bound (not in CI, which
# tests the newest versions; tests/test_min_versions.py keeps the pins and bounds in step).
VENV_MIN  := .venv-min

test-min:
	$(PYTHON) -m venv $(VENV_MIN)
	$(VENV_MIN)/bin/python -m pip install --quiet -e ".[scale,test]" -c .ci/min-versions.txt
	$(VENV_MIN)/bin/pytest -n 2 --dist loadfile
	$(VENV_MIN)/bin/kinsync demo --out demo-output-min

# numba's on-disk cache keys each kernel on its own module's source only: after editing a
# compiled helper that another module's kernel calls (ins/_ekf.py, ins/strapdown.py,
# ins/gnss_observation.py), clear it or the old helper stays compiled in.
clean-numba:
	find src -name '*.nbi' -delete -o -name '*.nbc' -delete

clean: clean-numba
	rm -rf $(VENV) $(VENV_MIN) demo-output demo-output-min .mypy_cache .ruff_cache .pytest_cache .hypothesis
