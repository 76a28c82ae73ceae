"""The fault matrix: each fault a plugin can commit (fault_plugins.FAULTS) at each place plugin
code runs (the optimizer's constructor, ask, tell, done, close; the problem's constructor,
evaluate, residuals, metrics, describe, the optimum polish and signals after the runs), run as
the command runs it (isolation=process, in the sweep's worker processes). Every cell: the job
ends within a bounded time; a fatal fault fails the run (in a constructor or describe(), the
job; after the runs, nothing but a warning) with its reason, a harmless one leaves the run ok;
no process the fault started outlives the cell; the next job on the same workers runs intact;
the command's folder is unchanged; and at the end one report over every cell is written."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest
from fault_plugins import (
    FATAL,
    FAULTS,
    OPTIMIZER_PLACES,
    PROBLEM_PLACES,
    FaultyOptimizer,
    FaultyProblem,
    FaultyResidualOptimizer,
)
from process_plugins import PIDS_ENV, left_running

from vpid_bench.experiment import run_job
from vpid_bench.spec import Job, JobSpec
from vpid_bench.workers import Workers

PS, ITERATIONS = 4, 2
#: What each fatal fault leaves in the failed record's error (type or message).
REASON = {"raise": "planted fault", "systemexit": "SystemExit", "exit": "exit code 3",
          "abort": "signal SIGABRT", "sleep": "run_timeout_s",
          "closepipe": "pipe to the sweep was closed"}
#: Places before any run: a fatal fault there fails the job (one line), not a run.
BEFORE_RUNS = ("constructor", "build", "describe")
#: Places after the runs: a fatal fault there is a warning; the runs stay ok.
AFTER_RUNS = ("polish", "signals")
#: A problem's constructor has START_S (120 s) before any limit applies: a 30 s sleep there is
#: no fault, and a cell that waits for it would take 30 s.
NOT_A_FAULT = {("sleep", "build")}
#: Each cell's grace_s: a worker deaf past its limit is killed 2 s later, not the default 10 s
#: (the default's own path: tests/hostile/test_misbehaving_plugins.py).
GRACE_S = 2.0


@pytest.fixture(scope="module")
def pids(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("pids")


@pytest.fixture(scope="module")
def pool(pids):
    before = os.environ.get(PIDS_ENV)
    os.environ[PIDS_ENV] = str(pids)  # the workers' processes note theirs there
    workers = Workers(1)
    yield workers
    workers.close()
    if before is None:
        os.environ.pop(PIDS_ENV, None)
    else:
        os.environ[PIDS_ENV] = before


@pytest.fixture(scope="module")
def cells(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("cells")


def _job(fault: str = "none", place: str = "none") -> Job:
    on_problem = place in PROBLEM_PLACES
    config = FaultyProblem.Config(ps=PS, iterations=ITERATIONS, fault=fault if on_problem
                                  else "none", place=place if on_problem else "none")
    cls = FaultyResidualOptimizer if place == "residuals" else FaultyOptimizer
    params = cls.Params(ps=PS, iterations=ITERATIONS, budget=PS * (ITERATIONS + 1),
                        fault="none" if on_problem else fault,
                        place="none" if on_problem else place)
    spec = JobSpec(runs=1, progress=False, report=False, run_timeout_s=1.0, isolation="process",
                   grace_s=GRACE_S)
    return Job(spec, "faulty", FaultyProblem, config, f"faulty-{fault}-{place}", cls, params,
               PS * (ITERATIONS + 1))


def _record(folder: Path) -> dict:
    (path,) = sorted((folder / "records").glob("run-*.json"))
    return json.loads(path.read_text())


#: Every cell; the default run keeps a quarter of them (a Latin pattern: each fault at three
#: places, each place under three faults, both ends of the supervisor's paths, a run's and a
#: job's), the rest run under ``-m slow`` (each cell is 1-3 s of waiting for a limit).
PLACES = OPTIMIZER_PLACES + PROBLEM_PLACES
CELLS = [pytest.param(fault, place, marks=() if (i + j) % 4 == 0 else pytest.mark.slow)
         for j, place in enumerate(PLACES) for i, fault in enumerate(FAULTS)
         if (fault, place) not in NOT_A_FAULT]


def _job_fails(fault: str, place: str) -> bool:
    """Whether the cell's job itself fails (before any run), rather than a run or nothing; a
    constructor past run_timeout_s fails every run instead (issue 35, failure 18)."""
    return place in BEFORE_RUNS and fault in FATAL and (fault, place) != ("sleep", "constructor")


@pytest.mark.parametrize(("fault", "place"), CELLS)
def test_a_fault_costs_its_run_or_job_only(pool, cells, pids, fault, place):
    here = os.getcwd()
    folder = cells / f"{fault}-{place}"
    t0 = time.monotonic()
    try:
        summary = run_job(_job(fault, place), folder, pool=pool)
    except Exception as exc:  # noqa: BLE001 - a fault before the runs stops its job
        assert _job_fails(fault, place), exc
        assert REASON[fault] in f"{getattr(exc, 'remote_type', '')} {exc}"
    else:
        assert not _job_fails(fault, place)
        record = _record(folder)
        if fault in FATAL and place not in AFTER_RUNS:
            assert summary.failed == [0] and record["status"] == "failed"
            error = record["error"]
            assert REASON[fault] in f"{error['type']} {error['message']}", error
        else:
            assert not summary.failed and record["status"] == "ok", record["error"]
        if place == "signals":  # closing the pipe ends the worker after the file is written
            written = fault not in FATAL or fault == "closepipe"
            assert (folder / "best_signals.csv").is_file() == written
    # warm-up + run, each bounded by run_timeout_s=1 (or killed grace_s after), plus start-up
    assert time.monotonic() - t0 < 2 * (1 + GRACE_S) + 20
    assert os.getcwd() == here
    assert left_running(pids) == []  # no process the fault started outlives its task
    other = run_job(_job(), cells / f"after-{fault}-{place}", pool=pool)
    assert other.ran == 1 and not other.failed


def test_one_report_over_every_cell(cells):
    """The short report reads, checks and tabulates every cell's records; the full one (tests
    and figures) those of the optimizer's places (one problem context: the problem's places
    make a context each, and drawing 80 of them takes minutes)."""
    from vpid_bench.report.build import build_report

    if not list(cells.glob("*/records/run-*.json")):
        pytest.skip("run with the matrix above")
    short = build_report([cells], cells / "report", short=True)
    assert (cells / "report" / "report.md").is_file() and short.failures
    optimizer_cells = [p for p in cells.iterdir() if p.name.rsplit("-", 1)[-1]
                       in OPTIMIZER_PLACES and list(p.glob("records/run-*.json"))]
    if not optimizer_cells:  # pytest-xdist gave this worker none of the optimizer's cells
        pytest.skip("no cell of the optimizer's places ran in this test process")
    full = build_report(optimizer_cells, cells / "report-full")
    assert (cells / "report-full" / "report.md").is_file() and full.failures
