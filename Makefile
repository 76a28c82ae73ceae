# Two commands do all the set-up on a fresh machine (Python >= 3.10 with venv):
#   make demo   install into .venv, run a small real benchmark, write its report
#   make test   install into .venv (with test extras), run ruff and the default tests
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
export MPLBACKEND := Agg

.PHONY: install demo test bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade "pip>=23.1"

$(VENV)/.installed: $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install -e ".[test,ioh,joblib,submitit,peers,tune]"
	touch $@

install: $(VENV)/.installed

demo: install
	$(BIN)/vpid-bench -m optimizer=de1,de4,ga,random problem.ps=20,30 hydra.sweep.dir=outputs/demo

test: install
	$(BIN)/ruff check .
	$(BIN)/python -m pytest

bench: install
	$(BIN)/python benchmarks/bench_vehicle.py
	$(BIN)/python benchmarks/bench_optimizers.py
	$(BIN)/python benchmarks/paper_experiment.py

clean:
	rm -rf $(VENV) outputs/*/ .pytest_cache
