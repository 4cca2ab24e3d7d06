# Two entry points, both self-contained on a fresh machine:
#   make paper   set up .venv, then run the paper's study into results/
#   make test    set up .venv, then ruff, then the test suite in serial and, for the tests not
#                marked serial, under mpiexec -n 2
# PYTHON must be 3.12 (the DOLFINx wheel needs it); .python-version makes pyenv's python3 one.
PYTHON ?= python3
VENV   ?= .venv
EXTRAS ?= dolfinx,test
BIN     = $(VENV)/bin

.PHONY: setup paper test bench clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info[:2] >= (3, 12) else "tissuebench needs Python >= 3.12, got " + sys.version.split()[0] + " (set PYTHON=python3.12)")'
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade --quiet pip
	$(BIN)/python -m pip install --quiet -e ".[$(EXTRAS)]"
	touch $@

paper: setup
	$(BIN)/tissuebench paper --out results

test: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/pytest
	$(BIN)/mpiexec -n 2 $(BIN)/pytest -q -m "not serial"

bench: setup
	$(BIN)/python -m pip install --quiet -e ".[bench]"
	$(BIN)/tissuebench bench --quick

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
