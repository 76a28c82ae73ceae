"""Calls shared out to several workers at once (``Workers.calls``): the job's optimum polishes
keep every worker busy instead of one polishing while the others wait. The calls run at the
same time, come back in their order, and one that fails, ends or hangs its worker costs
itself only; a job's optima, bounds and gaps are the same whether one worker or two polish."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from vpid_bench.experiment import run_job
from vpid_bench.spec import parse_job
from vpid_bench.workers import WorkerDiedError, WorkerKilledError, Workers

FUNCTIONS = ["problem=functions", "optimizer=random", "runs=2", "problem.iterations=2",
             "progress=false", "report=false"]


@pytest.fixture(scope="module")
def pool():
    workers = Workers(2)
    yield workers
    workers.close()


@pytest.fixture
def job(registry, compose_config):
    return parse_job(compose_config(FUNCTIONS), registry)


# module-level: a worker unpickles them by name (job, problem, *args)

def _meet(job, problem, folder: str, mine: str, theirs: str) -> int:
    """Say ``mine`` is here, then wait (20 s at most) for ``theirs``: only two calls running
    at once both return."""
    Path(folder, mine).touch()
    end = time.monotonic() + 20
    while not Path(folder, theirs).exists():
        if time.monotonic() > end:
            raise TimeoutError(f"{theirs} never came: the calls did not run at once")
        time.sleep(0.01)
    return os.getpid()


def _value(job, problem, v: int) -> int:
    return v


def _raise(job, problem) -> None:
    raise ValueError("a fault in the task")


def _exit(job, problem) -> None:
    os._exit(3)


def _hang(job, problem) -> None:
    time.sleep(60)


def test_calls_run_at_once_on_different_workers(pool, job, tmp_path):
    results = pool.calls(job, [(_meet, (str(tmp_path), "a", "b")),
                               (_meet, (str(tmp_path), "b", "a"))],
                         what="the meeting", limit=None, workers=2)
    assert [error for _, error in results] == [None, None]
    assert results[0][0] != results[1][0]  # two processes


def test_each_call_answers_in_its_place_and_a_fault_costs_itself_only(pool, job):
    results = pool.calls(job, [(_value, (1,)), (_raise, ()), (_exit, ()), (_value, (4,))],
                         what="the task", limit=None, workers=2)
    assert results[0] == (1, None) and results[3] == (4, None)
    assert results[1][0] is None and "a fault in the task" in str(results[1][1])
    assert getattr(results[1][1], "remote_type", type(results[1][1]).__name__) == "ValueError"
    assert isinstance(results[2][1], WorkerDiedError) and "exit code 3" in str(results[2][1])
    assert pool.call(job, _value, 5, what="the next call", limit=None) == 5


def test_a_call_that_hangs_is_killed_at_its_limit_and_the_others_answer(pool, job):
    t0 = time.monotonic()
    results = pool.calls(job, [(_hang, ()), (_value, (2,)), (_value, (3,))],
                         what="the task", limit=1.0, workers=2)
    assert time.monotonic() - t0 < 30  # not the 60 s the hanging call asks for
    assert isinstance(results[0][1], WorkerKilledError)
    assert "did not return within 1 s" in str(results[0][1])
    assert results[1:] == [(2, None), (3, None)]


def _files(folder: Path) -> dict[str, object]:
    return {str(p.relative_to(folder)): json.loads(p.read_text())
            for p in sorted(folder.rglob("*.json")) if "records" not in p.parts}


def test_a_jobs_optima_bounds_and_gaps_are_the_same_on_one_worker_or_two(
        registry, compose_config, tmp_path, pool, monkeypatch):
    """The vehicle problem (residuals, a truth, a choice of estimator): its optima, its
    per-problem files (bounds, floors per estimator) and the job's score, polished by one
    worker, then by two at once (one task per instance)."""
    shared = []
    calls = Workers.calls

    def spy(self, job, tasks, **kw):
        shared.append((len(tasks), kw["workers"]))
        return calls(self, job, tasks, **kw)

    monkeypatch.setattr(Workers, "calls", spy)
    base = ["problem=vehicle", "problem.iterations=3", "optimizer=de1", "runs=3",
            "progress=false", "report=false", "isolation=auto"]
    out = {}
    for workers in (1, 2):
        job = parse_job(compose_config([*base, f"workers={workers}"]), registry)
        folder = tmp_path / f"w{workers}"
        summary = run_job(job, folder / "job", registry, optima_dir=folder / "optima",
                          pool=pool)
        assert summary.ran == 3 and not summary.failed
        out[workers] = (summary.score, _files(folder))
    assert (4, 2) in shared  # the per-problem files and one task per instance, on 2 workers
    assert out[1][0] == out[2][0] and out[1][0] is not None
    assert out[1][1] == out[2][1]
    names = {Path(name).name for name in out[2][1]}
    assert {"identifiability.json", "estimators.json"} <= names
    assert len([n for n in out[2][1] if n.startswith("optima/") and n.count("/") == 1]) == 3
