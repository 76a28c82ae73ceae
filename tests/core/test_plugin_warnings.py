"""Warnings raised by plugin code during a job's runs (numpy's overflow warnings from a problem
whose residuals overflow) are one log line per group of runs, not raw lines on the terminal."""

from __future__ import annotations

import logging
import warnings

import numpy as np

from vpid_bench.api import Bounds, Optimizer, OptimizerParams, Problem, ProblemConfig
from vpid_bench.build import ProblemCache
from vpid_bench.job_runs import run_outcomes
from vpid_bench.spec import Job, JobSpec


class Overflowing(Problem):
    rows_independent = True

    @property
    def bounds(self) -> Bounds:
        return Bounds(-np.ones(2), np.ones(2), ("a", "b"))

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        big = np.full(X.shape[0], 1e300)
        return np.sum(X**2, axis=1) + np.minimum(big * big, 1.0)  # overflow: a warning


class Random(Optimizer):
    def ask(self) -> np.ndarray:
        return self.bounds.sample(self.rng, self.params.ps)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        pass


def test_warnings_from_plugin_code_are_one_line_per_group(caplog):
    job = Job(JobSpec(runs=3, progress=False, report=False), "overflowing", Overflowing,
              ProblemConfig(ps=4, iterations=5), "random", Random,
              OptimizerParams(ps=4, iterations=5, budget=24), 24)
    problem = ProblemCache().get(job)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning that escaped would fail the runs
        with caplog.at_level(logging.WARNING, logger="vpid_bench.job_runs"):
            outcomes = list(run_outcomes(job, problem, [0, 1, 2], lockstep=True))
    assert all(o.error is None for o in outcomes)
    lines = [r.getMessage() for r in caplog.records
             if "warning(s) from plugin code" in r.getMessage()]
    assert len(lines) == 1
    assert "random on overflowing, runs 0-2" in lines[0]
    assert "RuntimeWarning: overflow encountered" in lines[0]
    assert "test_plugin_warnings.py" in lines[0]


def test_the_warm_up_raises_no_raw_warning():
    """The untimed warm-up run (compilation) meets the same warnings as the runs; they are
    the runs' to report, so none leaves the warm-up (nevergrad's CMA once printed eight raw
    lines of cma's InjectionWarning per job of the archive build)."""
    from vpid_bench.job_runs import warm_up

    job = Job(JobSpec(runs=3, progress=False, report=False), "overflowing", Overflowing,
              ProblemConfig(ps=4, iterations=5), "random", Random,
              OptimizerParams(ps=4, iterations=5, budget=24), 24)
    problem = ProblemCache().get(job)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warm_up(job, problem, lockstep=True)
        problem.evaluate(np.zeros((1, 2)))  # the same call outside the warm-up does warn
    assert [str(w.message) for w in caught] == ["overflow encountered in multiply"]


class Quiet(Overflowing):
    def evaluate(self, X: np.ndarray) -> np.ndarray:
        return np.sum(X**2, axis=1)


class Chatty(Random):
    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        warnings.warn("first line\n    second line, indented\n" + "x" * 400, UserWarning,
                      stacklevel=1)


def test_a_long_warning_is_quoted_on_one_short_line(caplog):
    """cma's InjectionWarning is six indented lines: its group's log line quotes it on one
    line, cut to ``WARNING_CHARS``."""
    from vpid_bench.job_runs import WARNING_CHARS

    job = Job(JobSpec(runs=2, progress=False, report=False), "quiet", Quiet,
              ProblemConfig(ps=4, iterations=5), "chatty", Chatty,
              OptimizerParams(ps=4, iterations=5, budget=8), 8)
    problem = ProblemCache().get(job)
    with caplog.at_level(logging.WARNING, logger="vpid_bench.job_runs"):
        list(run_outcomes(job, problem, [0, 1], lockstep=True))
    (line,) = [r.getMessage() for r in caplog.records if "from plugin code" in r.getMessage()]
    assert "\n" not in line
    assert "UserWarning: first line second line, indented xxx" in line
    assert "x" * (WARNING_CHARS - 3) not in line and "...," in line
