# Two commands do all the set-up on a fresh machine (Python >= 3.10 with venv):
#   make demo   install into .venv, run a small real benchmark, write its report
#   make test   install into .venv (with test extras), run ruff and the default tests
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
export MPLBACKEND := Agg

.PHONY: install browser demo test test-slow bench bench-scale test-scaleout clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade "pip>=23.1"

# records-gpl/: third-party records under GPL-3.0, a separate data distribution (docs/measured.md)
# archive-runs/: the shipped archives' runs, a data distribution apart from the wheel
# (docs/sweeps.md), editable so that a rebuilt archive needs no reinstall.
# vpid-bench-compile: every plugin's numba loops compiled once into numba's cache (about 2
# min on 2 cores), so that no first run pays it (docs/usage.md)
$(VENV)/.installed: $(BIN)/python pyproject.toml records-gpl/pyproject.toml archive-runs/pyproject.toml
	$(BIN)/python -m pip install -e ".[test,ioh,joblib,submitit,peers,tune,fmu]"
	$(BIN)/python -m pip install ./records-gpl
	$(BIN)/python -m pip install -e ./archive-runs
	$(BIN)/vpid-bench-compile
	touch $@

install: $(VENV)/.installed

demo: install
	$(BIN)/vpid-bench -m optimizer=de1,de4,ga,random problem.ps=20,30 hydra.sweep.dir=outputs/demo

# Headless Chromium and its driver from Debian's packages, for the HTML report's browser
# tests (tests/report/test_html_browser.py): as root with apt-get (as CI runs), quick when
# already there; anywhere else it says so and the browser tests are skipped with the reason.
BROWSER_PKGS := chromium chromium-driver
APT_INSTALL := DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends
browser:
	@if [ -x /usr/bin/chromium ] && [ -x /usr/bin/chromedriver ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  echo "make browser: installing $(BROWSER_PKGS) from Debian's packages"; \
	  $(APT_INSTALL) $(BROWSER_PKGS) >/dev/null 2>&1 || { apt-get update -qq >/dev/null && \
	  $(APT_INSTALL) $(BROWSER_PKGS) >/dev/null; } || \
	  echo "make browser: could not install $(BROWSER_PKGS); the browser tests are skipped"; \
	else echo "make browser: not root or no apt-get; install $(BROWSER_PKGS) to run the" \
	  "browser tests (skipped without them)"; fi

test: install browser
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -n auto --dist worksteal --durations=15

# What the default run leaves out (-m slow, pyproject's addopts): the long experiments, the
# CLI re-proofs whose fast in-process twins the default run keeps, and the fuzz tests with ten
# times the examples. Tens of minutes on 2 cores.
test-slow: install browser
	$(BIN)/python -m pytest -n auto -m slow --durations=15

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

# Speed of the chain, worker processes, threads and a large study (minutes; docs/sweeps.md)
PAPER_SWEEP := --optimizers de1,de2,de3,de4,de5,de6,de7,de8,ga --ps 20,30
bench-scale: install
	$(BIN)/python benchmarks/bench_sweeps.py --ways default,report $(PAPER_SWEEP) \
	  --iterations 50 --runs-alone --report-alone --fixed-start
	$(BIN)/python benchmarks/bench_sweeps.py --ways none,threads $(PAPER_SWEEP) --iterations 500
	$(BIN)/python benchmarks/bench_sweeps.py
	$(BIN)/python benchmarks/bench_sweeps.py --ways default --report-alone --iterations 50 \
	  --optimizers de1,de2,de4,de8,jade,shade,lshade,ga,cmaes,scipy_de \
	  --problems vehicle,vehicle_long_record

bench: install
	$(BIN)/python benchmarks/bench_vehicle.py
	$(BIN)/python benchmarks/bench_optimizers.py
	$(BIN)/python benchmarks/bench_kernels.py core
	$(BIN)/python benchmarks/bench_kernels.py magic
	$(BIN)/python benchmarks/bench_overhead.py --skip nevergrad
	$(BIN)/python benchmarks/bench_sweeps.py --ways report,joblib $(PAPER_SWEEP) \
	  --iterations 50 --kernel --fixed-start
	$(BIN)/python benchmarks/bench_report.py

clean:
	rm -rf $(VENV) $(SCALEOUT_VENV) outputs/*/ .pytest_cache
