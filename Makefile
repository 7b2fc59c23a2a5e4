# Two commands do everything on a fresh machine with Python 3.11 and pip:
#   make demo   create .venv, install vrelab, run the article's ADXL355 case study with its report
#   make test   create .venv, install vrelab with its test extras, run the whole test suite
#   make docs   build the documentation into docs/_build/html
#   make examples  generate the example campaign's recordings (not committed; the three above run it)
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP_BASE := $(VENV)/.installed-base
STAMP_TEST := $(VENV)/.installed-test
STAMP_BENCH := $(VENV)/.installed-bench

.PHONY: demo test bench docs examples clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP_BASE): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(STAMP_TEST): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test,sweep,dask,formats,docs]"
	touch $@ $(STAMP_BASE)

$(STAMP_BENCH): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test,sweep,dask,formats,docs,bench]"
	touch $@ $(STAMP_TEST) $(STAMP_BASE)

# writes only what is missing (a few seconds the first time), so it runs on every call
examples: | $(STAMP_BASE)
	$(BIN)/python examples/make_campaign.py

demo: $(STAMP_BASE) examples
	$(BIN)/vrelab demo --out demo-out

# Two pytest workers on two cores: each process's BLAS keeps to one thread (OpenBLAS otherwise
# starts one per core in every process, and the workers' small solves wake them all: 4 or more
# busy threads on 2 cores; the identify and sweep tests took 59 s instead of 44 s).
# vrelab's bytecode written once before the suite: where the environment sets
# PYTHONDONTWRITEBYTECODE (this machine's does), no interpreter writes it, and each of the suite's
# CLI subprocesses compiled vrelab's modules from source again (0.6-0.8 s of CPU for the 83 modules
# an analysis imports). compileall writes __pycache__ (ignored by git) beside the sources.
test: $(STAMP_TEST) examples
	$(BIN)/python tests/setup_browser.py
	$(BIN)/python -m compileall -q src
	OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 $(BIN)/python -m pytest -n 2 --dist loadfile --no-loadscope-reorder

docs: $(STAMP_TEST) examples
	$(BIN)/python -m sphinx -b html -W --keep-going docs docs/_build/html

bench: $(STAMP_BENCH)
	$(BIN)/python bench/run_all.py

clean:
	rm -rf $(VENV) demo-out .pytest_cache docs/_build docs/auto_examples docs/api/generated
