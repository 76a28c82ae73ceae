"""Runs in lockstep (vpid_bench.runner.run_many, the job's lockstep path): every run's result
is bit-identical to the run alone, one failing or slow run fails alone, resume still skips."""

from __future__ import annotations

import time

import numpy as np
import pytest

from vpid_bench.api import Bounds, Optimizer, Problem
from vpid_bench.build import ProblemCache, run_rng
from vpid_bench.experiment import run_job
from vpid_bench.job_runs import joins_lockstep
from vpid_bench.runner import Lane, RunResult, RunTimeoutError, run, run_many
from vpid_bench.spec import parse_job
from vpid_bench.store import records as rec

FAST_VEHICLE = ["problem=vehicle", "problem.iterations=3", "progress=false", "report=false"]


def _same(a: RunResult, b: RunResult) -> None:
    """Two results equal in everything but time."""
    np.testing.assert_array_equal(a.x_best, b.x_best)
    assert (a.f_best, a.evaluations, a.budget, a.batches, a.stopped_by) == (
        b.f_best, b.evaluations, b.budget, b.batches, b.stopped_by)
    assert a.trace_evaluations == b.trace_evaluations
    assert a.trace_best == b.trace_best


def _job(registry, compose_config, overrides):
    return parse_job(compose_config(overrides), registry)


@pytest.mark.parametrize("optimizer", ["de4", "ga", "random", "jade", "cmaes"])
def test_run_many_equals_runs_alone_on_the_vehicle(registry, compose_config, optimizer):
    if optimizer not in registry.optimizers:
        pytest.skip(f"{optimizer} not installed (extra 'peers')")
    # Budgets differ per lane: one ends exactly at a generation, one cuts a batch, one is
    # longer than the optimizer's own iterations (it stops itself: stopped_by "optimizer").
    job = _job(registry, compose_config, [*FAST_VEHICLE, f"optimizer={optimizer}"])
    problem = ProblemCache().get(job)
    budgets = [job.budget, 47, 10 * job.budget, 20]

    def optimizer_for(i):
        return job.optimizer_cls(job.params, problem.bounds, run_rng(5, i))

    alone = [run(problem.instance(i), optimizer_for(i), b) for i, b in enumerate(budgets)]
    lanes = [Lane(problem.instance(i), optimizer_for(i), b, i) for i, b in enumerate(budgets)]
    together = run_many(problem, lanes)
    for a, b in zip(alone, together):
        _same(a, b)
    if optimizer in ("de4", "ga", "jade"):  # they end after their iterations
        assert {r.stopped_by for r in together} == {"budget", "optimizer"}
    assert together[1].evaluations == 47


def test_job_records_are_bit_identical_in_lockstep(registry, compose_config, tmp_path,
                                                   monkeypatch):
    job = _job(registry, compose_config, [*FAST_VEHICLE, "optimizer=de1", "runs=5"])
    assert joins_lockstep(job, ProblemCache().get(job))
    together = run_job(job, tmp_path / "lockstep", registry)
    monkeypatch.setattr("vpid_bench.experiment.joins_lockstep", lambda job, problem: False)
    alone = run_job(job, tmp_path / "alone", registry)
    assert together.ran == alone.ran == 5 and not together.failed

    def prints(summary):
        return [rec.fingerprint(rec.read_record(p)) for p in summary.record_paths]

    assert prints(together) == prints(alone)


def test_resume_skips_recorded_runs_and_runs_the_rest_in_lockstep(registry, compose_config,
                                                                  tmp_path):
    job = _job(registry, compose_config, [*FAST_VEHICLE, "optimizer=ga", "runs=4"])
    first = run_job(job, tmp_path, registry)
    before = [rec.fingerprint(rec.read_record(p)) for p in first.record_paths]
    first.record_paths[1].unlink()
    first.record_paths[3].unlink()
    again = run_job(job, tmp_path, registry)
    assert (again.skipped, again.ran) == (2, 2)
    assert [rec.fingerprint(rec.read_record(p)) for p in again.record_paths] == before


def test_loop_and_residual_optimizers_do_not_join(registry, compose_config):
    for name in ("lsq", "scipy_de"):
        job = _job(registry, compose_config, [*FAST_VEHICLE, f"optimizer={name}"])
        assert not joins_lockstep(job, ProblemCache().get(job)), name


# -- crash isolation and time limits, on a small problem of our own ----------------------------

class Square(Problem):
    """sum(x^2) on [-1, 1]^2, rows independent; instance i adds i (so rows must meet their own
    instance); rows of instance ``poison`` make ``evaluate`` raise."""

    name = "square"
    rows_independent = True

    def __init__(self, offset: float = 0.0, poison: int = -1) -> None:
        super().__init__(None)
        self.offset, self.poison = offset, poison
        self._bounds = Bounds(-np.ones(2), np.ones(2), ("a", "b"))
        self._instances: dict[int, Square] = {}

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    def instance(self, index: int) -> Problem:
        if index not in self._instances:
            self._instances[index] = Square(float(index), self.poison)
        return self._instances[index]

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        if self.offset == self.poison:
            raise RuntimeError("bad instance")
        return np.sum(X * X, axis=1) + self.offset


class Random(Optimizer):
    """Uniform batches of 4; ``fail_at``: raise in ``tell`` at that batch; ``sleep``: seconds
    spent in every ``ask``."""

    def __init__(self, rng, fail_at: int = -1, sleep: float = 0.0) -> None:
        super().__init__(None, Bounds(-np.ones(2), np.ones(2), ("a", "b")), rng)
        self.fail_at, self.sleep, self.batches = fail_at, sleep, 0

    def ask(self) -> np.ndarray:
        time.sleep(self.sleep)
        return self.bounds.sample(self.rng, 4)

    def tell(self, X, f) -> None:
        self.batches += 1
        if self.batches == self.fail_at:
            raise SystemExit("optimizer gave up")


def test_each_row_meets_its_own_instance_and_a_crash_fails_one_lane():
    problem = Square(poison=2)
    lanes = [Lane(problem.instance(0), Random(run_rng(0, 0)), 40, 0),
             Lane(problem.instance(1), Random(run_rng(0, 1), fail_at=3), 40, 1),
             Lane(problem.instance(2), Random(run_rng(0, 2)), 40, 2),
             Lane(problem.instance(3), Random(run_rng(0, 3)), 40, 3)]
    out = run_many(problem, lanes)
    assert isinstance(out[1], SystemExit)
    assert isinstance(out[2], RuntimeError) and "bad instance" in str(out[2])
    for i in (0, 3):
        _same(out[i], run(problem.instance(i), Random(run_rng(0, i)), 40))
        assert out[i].f_best >= i  # instance i's offset: the row met its own instance


def test_a_slow_run_times_out_alone():
    problem = Square()
    lanes = [Lane(problem, Random(run_rng(1, 0)), 400, 0),
             Lane(problem, Random(run_rng(1, 1), sleep=0.02), 400, 0),
             Lane(problem, Random(run_rng(1, 2), sleep=30.0), 400, 0)]  # hangs: the alarm
    t0 = time.perf_counter()
    out = run_many(problem, lanes, timeout_s=0.3)
    assert time.perf_counter() - t0 < 5
    assert isinstance(out[0], RunResult) and out[0].evaluations == 400
    assert isinstance(out[1], RunTimeoutError) and isinstance(out[2], RunTimeoutError)


def test_default_evaluate_instances_groups_rows_by_instance():
    problem = Square()
    X = np.random.default_rng(0).uniform(-1, 1, (7, 2))
    index = np.array([3, 0, 3, 1, 0, 5, 1])
    expected = [problem.instance(int(i)).evaluate(X[j:j + 1])[0] for j, i in enumerate(index)]
    np.testing.assert_array_equal(problem.evaluate_instances(X, index), expected)


def test_the_default_gathered_evaluation_builds_each_instance_once():
    """The default evaluate_instances keeps the instances it built: it is called once per
    step of the run loop, and a problem whose instance() makes a record (the suite's ride
    problems) spent most of a lockstep sweep rebuilding them (8x slower per evaluation)."""
    built = []

    class Counted(Problem):
        name = "counted"
        rows_independent = True

        def __init__(self, shift: float = 0.0) -> None:
            self.shift = shift

        @property
        def bounds(self):
            return Bounds(np.zeros(2), np.ones(2), ("a", "b"))

        def evaluate(self, X):
            return np.sum(X, axis=1) + self.shift

        def instance(self, index: int):
            built.append(index)
            return Counted(float(index))

    problem = Counted()
    X = np.full((6, 2), 0.25)
    index = np.array([0, 0, 1, 1, 2, 2])
    for _ in range(5):
        assert np.array_equal(problem.evaluate_instances(X, index), 0.5 + index)
    assert sorted(built) == [0, 1, 2]
