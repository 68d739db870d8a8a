# Two commands on a fresh machine with Python 3.11+ and make:
#   make demo   creates .venv, installs crankfmu with its dependencies, runs the main job
#   make test   same bootstrap, then the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
OUT    ?= build/demo

.PHONY: demo test venv fmu bench clean

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "crankfmu needs Python 3.11+, found " + sys.version' 
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	@touch $(STAMP)

venv: $(STAMP)

fmu: $(STAMP)
	$(BIN)/python fmu_build/build.py --dest build/fmus

demo: fmu
	$(BIN)/crankfmu simulate seed000 --out $(OUT)

test: fmu
	$(BIN)/python -m pytest -q

bench: fmu
	$(BIN)/python benchmarks/fmu_step.py

clean:
	rm -rf build .pytest_cache
