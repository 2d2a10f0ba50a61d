# optplan: two-command start.  `make demo` and `make test` each create .venv (python3 -m venv)
# and install optplan with its dev and docs extras on first use; later runs skip the install
# (a stamp file in .venv records it and is refreshed when pyproject.toml changes).

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.optplan-installed

export NO_MKDOCS_2_WARNING := 1

.PHONY: demo test lint docs docs-serve bench clean distclean help

help:
	@echo "make demo       the main job: paper-warehouse with hybrid-paper (table, PNG and GIF under runs/)"
	@echo "make test       ruff + pytest (not slow; mypy and mkdocs build --strict among the tests)"
	@echo "make bench      run the speed benchmarks in benchmarks/"
	@echo "make docs       build the documentation site into site/"
	@echo "make clean      remove build artefacts (make distclean also removes .venv)"

$(BIN)/python:
	@$(PYTHON) -m venv $(VENV) || { echo "error: '$(PYTHON) -m venv' failed; install the venv module (e.g. apt install python3-venv)" >&2; exit 1; }

$(STAMP): pyproject.toml | $(BIN)/python
	@echo "installing optplan[dev,docs] into $(VENV) (first run only; a few minutes)"
	@# the build backend first, then an editable install without pip's isolated build
	@# environment: the wheel hook's build dependencies (numba, scipy, ...: hatch_build.py) are
	@# only needed for a wheel (an isolated environment would fetch and unpack them every time)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check 'hatchling>=1.21' editables
	$(BIN)/python -m pip install --quiet --disable-pip-version-check --no-build-isolation -e '.[dev,docs]'
	@# the wheel ships its kernels compiled; a checkout compiles them here, once, for this CPU
	@# into numba's cache (__pycache__), so that the first solves load them instead
	@echo "compiling the numba kernels for this machine (first run only; about half a minute)"
	$(BIN)/python -c "from optplan.geometry.compiled.kernel_cache import compile_all; compile_all()"
	@touch $@

demo: $(STAMP)
	$(BIN)/python -m optplan.experiments.demo

test: $(STAMP)
	$(BIN)/ruff check .
	@# mypy and `mkdocs build --strict` are tests (tests/tools/test_static_checks.py): one
	@# xdist worker runs them while the other runs other tests; files are handed out in
	@# collection order, the longest first (tests/conftest.py), not by their test counts
	$(BIN)/python -m pytest -m "not slow" -q -n 2 --dist loadfile --no-loadscope-reorder

lint: $(STAMP)
	$(BIN)/ruff check .

docs: $(STAMP)
	$(BIN)/mkdocs build --strict

docs-serve: $(STAMP)
	$(BIN)/mkdocs serve

bench: $(STAMP)
	@for f in benchmarks/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

clean:
	rm -rf site build dist .pytest_cache .ruff_cache .mypy_cache .hypothesis
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV)
