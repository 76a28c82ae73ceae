"""``optimizer=nevergrad`` (extra ``peers``): the method name check, batches of ps, seeding,
failures inside nevergrad recorded as failed runs, better than random search. Skipped when
nevergrad is not installed. About 10 s, 3 of them ``import nevergrad``."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from extras import limit
from peers_helpers import run_optimizer
from scipy.stats import mannwhitneyu

from vpid_bench.api import ConfigError
from vpid_bench.build import build_problem
from vpid_bench.experiment import run_from_config
from vpid_bench.params import build_dataclass
from vpid_bench.store.records import read_record

ng = pytest.importorskip("nevergrad")

from vpid_peers.nevergrad_opt import NevergradOptimizer, NevergradParams  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")  # nevergrad's own advice


def _problem(registry, function: str = "sphere", dim: int = 5, ps: int = 10, iterations: int = 20):
    return build_problem(registry, {"name": "functions", "function": function, "dim": dim,
                                    "ps": ps, "iterations": iterations})


_run = run_optimizer


def test_registered_so_the_contract_test_covers_it(registry):
    # tests/optimizers/test_optimizer_contract.py runs every name of Registry().optimizers
    assert registry.optimizer("nevergrad") is NevergradOptimizer


def test_registering_imports_neither_library():
    """Start-up stays fast: finding the plugins imports neither nevergrad (~3 s) nor cma."""
    code = ("import sys; from vpid_bench.plugins import Registry; r = Registry(); "
            "assert {'cmaes', 'nevergrad'} <= set(r.optimizers); "
            "print(sorted(m for m in ('nevergrad', 'cma') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, "MPLBACKEND": "Agg"}, timeout=limit(120))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_unknown_method_is_one_line_listing_close_names():
    with pytest.raises(ConfigError) as info:
        build_dataclass(NevergradParams, {"method": "NGopt"}, prefix="optimizer")
    message = str(info.value)
    assert info.value.key == "optimizer.method"
    assert "\n" not in message
    assert message.startswith("optimizer.method='NGopt' is not allowed")
    assert "NGOpt" in message.split("closest:")[1]
    with pytest.raises(ConfigError, match=r"closest: CMA\b"):
        build_dataclass(NevergradParams, {"method": "cma"}, prefix="optimizer")
    with pytest.raises(ConfigError, match="no close name"):
        build_dataclass(NevergradParams, {"method": "zzzzqqqq"}, prefix="optimizer")
    assert build_dataclass(NevergradParams, {"method": "NGOpt"}).method == "NGOpt"


def test_batches_of_ps_and_the_protocol_schedule(registry):
    """With batch=ps every batch is ps rows; a run budget above ps x (iterations + 1) is not
    used."""
    problem = _problem(registry, ps=7, iterations=4)
    result, _ = _run(registry, "nevergrad", problem, seed=0, budget=1000, batch="ps")
    assert np.diff([0, *result.trace_evaluations]).tolist() == [7] * 5
    assert result.evaluations == 35 and result.stopped_by == "optimizer"


def test_nevergrads_default_asks_one_candidate_at_a_time(registry):
    """batch=library (the default): num_workers 1, so every batch is one row."""
    problem = _problem(registry, ps=7, iterations=4)
    result, _ = _run(registry, "nevergrad", problem, seed=0)
    assert np.diff([0, *result.trace_evaluations]).tolist() == [1] * 35
    assert result.evaluations == 35


@pytest.fixture(scope="module")
def random_sphere(registry):
    return np.array([_run(registry, "random", _problem(registry), s)[0].f_best
                     for s in range(10)])


@pytest.mark.parametrize("method", ["CMA", "TwoPointsDE", "TBPSA"])
def test_beats_random_search_on_sphere(registry, random_sphere, method):
    """5-D sphere, 10 x 21 evaluations, 10 seeds each: a one-sided rank test against random
    search gives p < 0.01 and the median is less than half random's. Measured over 20 seeds:
    random's median best 5.9 (2.0 at best), CMA 0.24, TwoPointsDE 1.6, TBPSA 0.05."""
    problem = _problem(registry)
    theirs = np.array([_run(registry, "nevergrad", problem, s, method=method)[0].f_best
                       for s in range(10)])
    assert mannwhitneyu(theirs, random_sphere, alternative="less").pvalue < 0.01
    assert np.median(theirs) < 0.5 * np.median(random_sphere)


def test_same_seed_same_run_whatever_the_global_rng(registry):
    problem = _problem(registry, ps=6, iterations=5)
    np.random.seed(1)
    first, _ = _run(registry, "nevergrad", problem, seed=11)
    np.random.seed(2)
    np.random.rand(17)
    again, _ = _run(registry, "nevergrad", problem, seed=11)
    np.testing.assert_array_equal(again.x_best, first.x_best)
    assert again.trace_best == first.trace_best
    other, _ = _run(registry, "nevergrad", problem, seed=12)
    assert other.trace_best != first.trace_best


class _Broken(ng.optimizers.base.Optimizer):
    """A nevergrad optimizer that fails on its third ask, as a buggy method would."""

    def __init__(self, parametrization, budget=None, num_workers=1):
        super().__init__(parametrization, budget=budget, num_workers=num_workers)

    def _internal_ask_candidate(self):
        if self.num_ask >= 2:
            raise RuntimeError("broken inside nevergrad")
        return self.parametrization.spawn_child()


def _job(compose_config, tmp_path, method: str, runs: int = 2):
    cfg = compose_config(["problem=functions", "problem.dim=4", "problem.ps=20",
                          "problem.iterations=5", "optimizer=nevergrad",
                          f"optimizer.method={method}", f"runs={runs}", "progress=false",
                          "report=false"])
    summary = run_from_config(cfg, tmp_path / method)
    return summary, [read_record(p) for p in summary.record_paths]


def test_a_method_that_raises_is_a_failed_run(compose_config, tmp_path, monkeypatch):
    monkeypatch.setitem(ng.optimizers.registry, "BrokenForTest", _Broken)
    summary, records = _job(compose_config, tmp_path, "BrokenForTest")
    assert summary.ran == 2 and summary.failed == [0, 1]
    assert [r["status"] for r in records] == ["failed", "failed"]
    assert records[0]["error"]["type"] == "RuntimeError"
    assert "broken inside nevergrad" in records[0]["error"]["message"]


def test_a_record_names_nevergrad_and_its_version(compose_config, tmp_path):
    summary, records = _job(compose_config, tmp_path, "CMA", runs=1)
    assert records[0]["status"] == "ok"
    assert records[0]["optimizer"]["plugin"]["library"] == {"name": "nevergrad",
                                                             "version": ng.__version__}


def test_runs_nevergrad_itself(registry):
    """The optimizer asked and told is the registry's own class (the CMA wrapper), nothing
    replaced or bypassed."""
    from vpid_bench.build import optimizer_params, run_rng

    problem = _problem(registry, dim=3)
    cls, params = optimizer_params(registry, {"name": "nevergrad", "budget": 50})
    optimizer = cls(params, problem.bounds, run_rng(1, 0))
    optimizer.ask()
    assert type(optimizer._ng) is ng.optimizers.registry["CMA"]


def test_ngopt_at_a_small_budget_never_crashes_the_job(compose_config, tmp_path):
    """NGOpt with 4 parameters and 120 evaluations raises a TypeError inside nevergrad 1.0.12's
    metamodel on numpy 2.x. Whatever nevergrad does here, every run ends with a record: ok, or
    failed with nevergrad's error in it."""
    summary, records = _job(compose_config, tmp_path, "NGOpt")
    assert summary.ran == 2 and len(records) == 2
    for record in records:
        assert record["status"] in ("ok", "failed")
        if record["status"] == "failed":
            assert record["error"]["type"] and "nevergrad" in record["error"]["traceback"]
