"""The vehicle's gathered evaluation (runs in lockstep fitting different noise records): each
row against its own instance's reference, equal to per-instance evaluation."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from vpid_vehicle.objective import add_noise

from vpid_bench.build import ProblemCache, run_rng
from vpid_bench.runner import Lane, run, run_many
from vpid_bench.spec import parse_job


@pytest.fixture(scope="module")
def noisy(registry, compose_config):
    """A vehicle problem whose instance i has its own noise record (as per-run noise will):
    the same simulator, another reference."""
    job = parse_job(compose_config(["problem=vehicle", "problem.iterations=2",
                                    "problem.noise.level=0.05"]), registry)
    base = ProblemCache().get(job)
    instances = {}

    def instance(i: int):
        if i not in instances:
            inst = copy.copy(base)
            inst.reference = add_noise(base.reference_clean, 0.05, "multiplicative",
                                       np.random.default_rng(100 + i))
            inst.reference.setflags(write=False)
            instances[i] = inst
        return instances[i]

    base.instance = instance
    return job, base


def test_kernel_rows_against_their_own_reference_equal_one_reference_at_a_time(noisy):
    _, problem = noisy
    rng = np.random.default_rng(1)
    X = np.vstack([problem.bounds.sample(rng, 37), problem.bounds.lower[None] * 0.0])  # + a bad row
    index = rng.integers(0, 5, X.shape[0])
    f = problem.evaluate_instances(X, index)
    alone = np.array([problem.instance(int(i)).evaluate(X[j:j + 1])[0]
                      for j, i in enumerate(index)])
    np.testing.assert_allclose(f, alone, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(f, alone)  # in fact bit for bit
    assert np.isinf(f[-1]) and np.all(np.isfinite(f[:-1]))
    refs = {int(i): problem.instance(int(i)).reference for i in index}
    assert len({r.tobytes() for r in refs.values()}) == len(refs)  # the references differ


def test_threads_do_not_change_gathered_values(noisy):
    _, problem = noisy
    rng = np.random.default_rng(2)
    X = problem.bounds.sample(rng, 300)
    index = np.repeat(np.arange(15), 20)
    problem.set_threads(1)
    one = problem.evaluate_instances(X, index)
    problem.set_threads(2)
    two = problem.evaluate_instances(X, index)
    problem.set_threads(1)
    np.testing.assert_array_equal(one, two)


def test_lockstep_runs_on_distinct_instances_equal_runs_alone(noisy):
    job, problem = noisy

    def optimizer_for(i):
        return job.optimizer_cls(job.params, problem.bounds, run_rng(0, i))

    alone = [run(problem.instance(i), optimizer_for(i), job.budget) for i in range(4)]
    together = run_many(problem, [Lane(problem.instance(i), optimizer_for(i), job.budget, i)
                                  for i in range(4)])
    for a, b in zip(alone, together):
        np.testing.assert_array_equal(a.x_best, b.x_best)
        assert a.trace_best == b.trace_best and a.f_best == b.f_best


def test_a_sweeps_jobs_build_each_instance_once(registry, compose_config, tmp_path,
                                                monkeypatch):
    """Every place a job needs instance i (the lockstep call, its record, the optimum
    analysis, the floors, the best run's signals) gets the one kept on the problem
    (``vpid_bench.problem.kept_instance``): a suite member solves its record exactly when
    an instance is built, and a job once built each about eight times. The sweep's later
    jobs on the same problem (one ProblemCache) build none; the floors per estimator and the
    bounds are made once per sweep (``optima/per-problem/``) and copied."""
    from vpid_vehicle.ride import problem as ride

    from vpid_bench.experiment import run_job

    built: list[int] = []
    real = ride.RideProblem.__init__

    def counted(self, config, index=0):
        built.append(index)
        real(self, config, index)

    monkeypatch.setattr(ride.RideProblem, "__init__", counted)
    cache = ProblemCache()
    jobs = {}
    for name in ("random", "de1"):
        jobs[name] = parse_job(compose_config([
            "problem=smoke_quarter", f"optimizer={name}", "runs=3", "isolation=none",
            "progress=false", "report=false"]), registry)
    run_job(jobs["random"], tmp_path / "random", registry, cache, tmp_path / "optima")
    # each instance once per objective: the job's problem, and the floors' problem under each
    # other objective (its own weights), instances 0-2 each
    from vpid_bench.estimators import OBJECTIVES

    assert {i: built.count(i) for i in (0, 1, 2)} == dict.fromkeys((0, 1, 2), len(OBJECTIVES))
    assert len(built) == 3 * len(OBJECTIVES)
    built.clear()
    run_job(jobs["de1"], tmp_path / "de1", registry, cache, tmp_path / "optima")
    assert built == []
    for f in ("estimators.json", "identifiability.json"):
        assert (tmp_path / "de1" / f).read_text() == (tmp_path / "random" / f).read_text()
