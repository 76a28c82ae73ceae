"""The run's budget is handed to the optimizer by the job (``params.budget``, read as
``Optimizer.budget``), computed once (``default_budget``), equal to what the run loop allows,
and not settable on the optimizer."""

from __future__ import annotations

import numpy as np
import pytest

from vpid_bench import ConfigError, default_budget
from vpid_bench.build import run_rng
from vpid_bench.runner import run
from vpid_bench.spec import parse_job

FAST = ["problem=functions", "problem.function=sphere", "problem.dim=3", "runs=1"]


def _job(compose_config, registry, *overrides):
    return parse_job(compose_config([*FAST, *overrides]), registry)


def test_the_default_budget_is_the_protocol_formula(compose_config, registry):
    job = _job(compose_config, registry, "problem.ps=7", "problem.iterations=4")
    assert job.budget == default_budget(7, 4) == 7 * 5
    assert job.params.budget == job.budget and job.params.ps == 7


@pytest.mark.parametrize("optimizer", ["de4", "lshade", "cmaes", "random", "de_lsq"])
def test_budget_n_reaches_the_optimizer_and_the_run_loop(compose_config, registry, optimizer):
    job = _job(compose_config, registry, f"optimizer={optimizer}", "budget=53")
    assert job.budget == 53 and job.params.budget == 53
    problem = registry.problem("functions")(job.problem_config)
    opt = job.optimizer_cls(job.params, problem.bounds, np.random.default_rng(0))
    assert opt.budget == 53
    result = run(problem, opt, budget=job.budget)
    assert result.evaluations <= 53


@pytest.mark.parametrize("key", ["budget", "ps", "iterations"])
def test_the_filled_keys_are_refused_on_the_optimizer(compose_config, registry, key):
    with pytest.raises(ConfigError) as err:
        _job(compose_config, registry, f"+optimizer.{key}=10")
    assert err.value.key == f"optimizer.{key}"
    assert "the job fills it in" in str(err.value)


def test_run_rng_is_the_documented_stream():
    a = run_rng(3, 2).random(4)
    b = np.random.default_rng(np.random.SeedSequence(3, spawn_key=(2,))).random(4)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("optimizer", ["de4", "lshade", "cmaes"])
def test_budget_per_dim_sizes_the_budget_by_the_problems_dimension(compose_config, registry,
                                                                   optimizer):
    job = _job(compose_config, registry, f"optimizer={optimizer}", "budget_per_dim=17")
    problem = registry.problem("functions")(job.problem_config)
    sized = job.sized(problem.bounds.dim)
    assert sized.budget == 17 * 3 == sized.params.budget
    opt = sized.optimizer_cls(sized.params, problem.bounds, np.random.default_rng(0))
    assert opt.budget == 51
    assert run(problem, opt, budget=sized.budget).evaluations <= 51
    assert job.sized(3) == sized and _job(compose_config, registry).sized(3).budget == 20 * 51


@pytest.mark.parametrize("overrides, line", [
    (["budget=50", "budget_per_dim=10"], "either budget= or budget_per_dim=, not both"),
    (["budget_per_dim=0"], "budget_per_dim=0 is not allowed"),
])
def test_bad_budget_per_dim_is_refused(compose_config, registry, overrides, line):
    with pytest.raises(ConfigError, match=line):
        _job(compose_config, registry, *overrides)


def test_a_budget_per_dim_beyond_the_largest_budget_is_refused(compose_config, registry):
    job = _job(compose_config, registry, "budget_per_dim=400000000")
    with pytest.raises(ConfigError, match="at most 333333333 for a problem of 3 parameters"):
        job.sized(3)
