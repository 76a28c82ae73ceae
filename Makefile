# Two commands do all the set-up on a fresh machine (Python >= 3.10 with venv):
#   make demo   install into .venv, run a small real benchmark, write its report
#   make test   install into .venv (with test extras), run ruff and the default tests
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
export MPLBACKEND := Agg

.PHONY: install demo test bench bench-scale test-scaleout clean

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

# Launchers beyond one process (Ray on a local instance, submitit's local executor): their
# own environment, every extra in ONE pip run (the Ray launcher pins cloudpickle<3), so the
# default install stays free of Ray. Records must be bit-identical to the basic launcher's.
SCALEOUT_VENV ?= .venv-scaleout
$(SCALEOUT_VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(SCALEOUT_VENV)
	$(SCALEOUT_VENV)/bin/python -m pip install --upgrade "pip>=23.1"
	$(SCALEOUT_VENV)/bin/python -m pip install -e ".[test,joblib,submitit,ray]"
	touch $@

test-scaleout: $(SCALEOUT_VENV)/.installed
	$(SCALEOUT_VENV)/bin/python -m pytest -m scaleout tests/sweeps/test_launchers.py

# Speed of the chain, lockstep and threads (minutes; see docs/sweeps.md)
bench-scale: install
	$(BIN)/python benchmarks/bench_chain.py
	$(BIN)/python benchmarks/bench_threads_sweep.py
	$(BIN)/python benchmarks/bench_workers.py
	$(BIN)/python benchmarks/bench_large_study.py

bench: install
	$(BIN)/python benchmarks/bench_vehicle.py
	$(BIN)/python benchmarks/bench_optimizers.py
	$(BIN)/python benchmarks/bench_magic.py
	$(BIN)/python benchmarks/bench_overhead.py --skip nevergrad
	$(BIN)/python benchmarks/paper_experiment.py
	$(BIN)/python benchmarks/bench_report.py

clean:
	rm -rf $(VENV) $(SCALEOUT_VENV) outputs/*/ .pytest_cache
