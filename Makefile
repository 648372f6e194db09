# One virtual environment at .venv; every target sets it up first.
PYTHON ?= python3
TORCH_VERSION ?= 2.13.0
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup test test-fast demo demo-paper bench clean

$(STAMP): pyproject.toml Makefile
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	# pinned so pip takes the CPU wheel instead of resolving a multi-GB CUDA build; override TORCH_VERSION
	$(BIN)/pip install --quiet torch==$(TORCH_VERSION)
	$(BIN)/pip install --quiet -e ".[test]"
	touch $(STAMP)

setup: $(STAMP)

# the suite in TEST_WORKERS processes of one thread each (test files kept whole): much of it is
# Python-bound (imports, kernel compiles, plots), so one process of two threads left a core idle
# (2 cores: 493 s against 926 s, session 16). Plain `pytest` still runs it in one process.
TEST_WORKERS ?= 2
test: $(STAMP)
	OMP_NUM_THREADS=1 $(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile

# the edit loop: no Mitsuba cross-checks, end-to-end fits, killed-and-resumed processes or torchrun
test-fast: $(STAMP)
	OMP_NUM_THREADS=1 $(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile -m "not slow"

demo: $(STAMP)
	$(BIN)/python -m nlos_spotlight.demo --out out/demo

# the paper's pipeline in procedural rooms (generate -> train -> evaluate: Tables 1-3, Figs. 5-7)
demo-paper: $(STAMP)
	$(BIN)/python -m nlos_spotlight.demo --paper --out out/demo-paper

bench: $(STAMP)
	$(BIN)/python benchmarks/render_speed.py
	$(BIN)/python benchmarks/render_vs_mitsuba.py
	$(BIN)/python benchmarks/render_throughput.py

clean:
	rm -rf $(VENV) out
