"""The fault matrix: each fault a plugin can commit (fault_plugins.FAULTS) at each place plugin
code runs (the optimizer's constructor, ask, tell, done, close; the problem's evaluate and
residuals), run as the command runs it (isolation=process, in the sweep's worker processes).
Every cell: the job ends within a bounded time; a fatal fault fails the run (or, in the
constructor, the job) with its reason, a harmless one leaves the run ok; the next job on the
same workers runs intact; the command's folder is unchanged; and at the end one report over
every cell is written."""

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

from vpid_bench.experiment import run_job
from vpid_bench.spec import Job, JobSpec
from vpid_bench.workers import GRACE_S, Workers

PS, ITERATIONS = 4, 2
#: What each fatal fault leaves in the failed record's error (type or message).
REASON = {"raise": "planted fault", "systemexit": "SystemExit", "exit": "exit code 3",
          "abort": "signal SIGABRT", "sleep": "run_timeout_s"}


@pytest.fixture(scope="module")
def pool():
    workers = Workers(1)
    yield workers
    workers.close()


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
    spec = JobSpec(runs=1, progress=False, report=False, run_timeout_s=1.0, isolation="process")
    return Job(spec, "faulty", FaultyProblem, config, f"faulty-{fault}-{place}", cls, params,
               PS * (ITERATIONS + 1))


def _record(folder: Path) -> dict:
    (path,) = sorted((folder / "records").glob("run-*.json"))
    return json.loads(path.read_text())


@pytest.mark.parametrize("place", OPTIMIZER_PLACES + PROBLEM_PLACES)
@pytest.mark.parametrize("fault", FAULTS)
def test_a_fault_costs_its_run_or_job_only(pool, cells, fault, place):
    here = os.getcwd()
    folder = cells / f"{fault}-{place}"
    t0 = time.monotonic()
    try:
        summary = run_job(_job(fault, place), folder, pool=pool)
    except Exception as exc:  # noqa: BLE001 - a constructor's fault stops its job before any run
        assert place == "constructor" and fault in FATAL, exc
        assert REASON[fault] in f"{getattr(exc, 'remote_type', '')} {exc}"
    else:
        record = _record(folder)
        if fault in FATAL:
            assert summary.failed == [0] and record["status"] == "failed"
            error = record["error"]
            assert REASON[fault] in f"{error['type']} {error['message']}", error
        else:
            assert not summary.failed and record["status"] == "ok", record["error"]
    # warm-up + run, each bounded by run_timeout_s=1 (or killed GRACE_S after), plus start-up
    assert time.monotonic() - t0 < 2 * (1 + GRACE_S) + 20
    assert os.getcwd() == here
    other = run_job(_job(), cells / f"after-{fault}-{place}", pool=pool)
    assert other.ran == 1 and not other.failed


def test_one_report_over_every_cell(cells):
    from vpid_bench.report.build import build_report

    if not list(cells.glob("*/records/run-*.json")):
        pytest.skip("run with the matrix above")
    report = build_report([cells], cells / "report")
    assert (cells / "report" / "report.md").is_file()
    assert report is not None
