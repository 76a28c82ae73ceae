"""The bridge for loop-owning optimizers (vpid_bench.api.LoopOptimizer): the budget ending
inside the library's loop, exceptions inside it, no thread left alive."""

from __future__ import annotations

import numpy as np
import pytest
from peers_helpers import LinearLSQ, NoResiduals, loop_threads

from vpid_bench import hookimpl
from vpid_bench.api import LoopOptimizer, OptimizerParams
from vpid_bench.runner import run


class LibraryError(RuntimeError):
    pass


class Toy(LoopOptimizer):
    """A library loop: batches of 3 uniform rows, ``batches`` of them (None: forever), then
    returns the best value it saw; raises after ``fail_after`` batches when set; optionally
    swallows every Exception around evaluate, as a careless library would."""

    batches: int | None = None
    fail_after: int | None = None
    swallow = False

    def __init__(self, params=None, bounds=None, rng=None):
        super().__init__(params or OptimizerParams(), bounds, rng or np.random.default_rng(0))
        self.seen: list[np.ndarray] = []
        self.exited_cleanly = False

    def minimize(self, evaluate):
        best, k = np.inf, 0
        try:
            while self.batches is None or k < self.batches:
                if self.fail_after is not None and k == self.fail_after:
                    raise LibraryError(f"diverged after {k} batches")
                X = self.bounds.sample(self.rng, 3)
                try:
                    f = evaluate(X)
                except Exception:  # noqa: BLE001 - the careless library
                    if not self.swallow:
                        raise
                    continue
                self.seen.append(f)
                best = min(best, float(np.min(f)))
                k += 1
        finally:
            self.exited_cleanly = True  # the library's own clean-up runs when it is stopped
        return best


def _problem():
    return NoResiduals()


def test_budget_ending_inside_the_library_loop_stops_it_and_leaves_no_thread():
    before = loop_threads()
    problem = _problem()
    opt = Toy(bounds=problem.bounds)
    result = run(problem, opt, budget=10)  # batches of 3: 3 + 3 + 3 + 1 (cut)
    assert result.evaluations == problem.evaluated == 10 and result.stopped_by == "budget"
    assert len(opt.seen) == 3  # the cut batch is never told
    assert opt.exited_cleanly and loop_threads() == before
    assert opt._thread is not None and not opt._thread.is_alive()


def test_stop_reaches_a_library_that_swallows_exceptions():
    problem = _problem()
    opt = Toy(bounds=problem.bounds)
    opt.swallow = True
    run(problem, opt, budget=7)
    assert opt.exited_cleanly and loop_threads() == []


def test_library_returning_ends_the_run_with_its_result():
    problem = _problem()
    opt = Toy(bounds=problem.bounds)
    opt.batches = 2
    result = run(problem, opt, budget=100)
    assert result.stopped_by == "optimizer" and result.evaluations == 6
    assert opt.done and opt.result == pytest.approx(result.f_best)
    assert loop_threads() == []


@pytest.mark.parametrize("fail_after", [0, 2])
def test_exception_inside_the_library_fails_the_run(fail_after):
    problem = _problem()
    opt = Toy(bounds=problem.bounds)
    opt.fail_after = fail_after
    with pytest.raises(LibraryError, match=f"after {fail_after} batches"):
        run(problem, opt, budget=100)
    assert problem.evaluated == 3 * fail_after and loop_threads() == []


def test_ask_twice_gives_the_same_batch_and_tell_checks_it():
    problem = _problem()
    with Toy(bounds=problem.bounds) as opt:
        X = opt.ask()
        np.testing.assert_array_equal(opt.ask(), X)
        with pytest.raises(ValueError, match="whole batch"):
            opt.tell(X[:2], np.zeros(2))
        opt.tell(X, problem.evaluate(X))
        assert not np.array_equal(opt.ask(), X)
    assert loop_threads() == [] and opt.done


def test_same_seed_same_run_through_the_thread():
    runs = []
    for _ in range(2):
        problem = _problem()
        runs.append(run(problem, Toy(bounds=problem.bounds, rng=np.random.default_rng(5)), 30))
    np.testing.assert_array_equal(runs[0].x_best, runs[1].x_best)
    assert runs[0].trace_best == runs[1].trace_best


class ResidualToy(LoopOptimizer):
    wants_residuals = True

    def minimize(self, evaluate):
        self.got = evaluate(self.bounds.sample(self.rng, 2))
        return "ok"


def test_residuals_reach_the_library_as_f_and_r():
    rng = np.random.default_rng(0)
    problem = LinearLSQ(rng.normal(size=(5, 2)), rng.normal(size=5), -1.0, 1.0)
    opt = ResidualToy(OptimizerParams(), problem.bounds, np.random.default_rng(1))
    result = run(problem, opt, budget=10)
    f, R = opt.got
    assert f.shape == (2,) and R.shape == (2, 5) and result.evaluations == 2
    assert opt.result == "ok"


class FailingPlugin:
    """Registers the toy with a library that fails after one batch."""

    class Failing(Toy):
        fail_after = 1

    @hookimpl
    def vpid_bench_register_optimizers(self, register):
        register("toy_failing", self.Failing)
        register("toy_forever", Toy)


def test_the_job_records_a_library_failure_and_goes_on(tmp_path):
    from vpid_bench.experiment import run_from_config
    from vpid_bench.plugins import Registry, get_plugin_manager
    from vpid_bench.store.records import read_record

    registry = Registry(get_plugin_manager(extra_plugins=[("toys", FailingPlugin())]))
    base = {"seed": 0, "runs": 2, "progress": False, "report": False,
            "problem": {"name": "functions", "function": "sphere", "dim": 3, "ps": 5,
                        "iterations": 3}}
    summary = run_from_config(base | {"optimizer": {"name": "toy_failing"}}, tmp_path / "a",
                              registry)
    assert summary.failed == [0, 1]
    record = read_record(summary.record_paths[0])
    assert record["status"] == "failed" and record["error"]["type"] == "LibraryError"
    summary = run_from_config(base | {"optimizer": {"name": "toy_forever"}}, tmp_path / "b",
                              registry)
    assert not summary.failed
    record = read_record(summary.record_paths[1])
    assert record["status"] == "ok" and record["result"]["evaluations"] == 20
    assert record["error"] is None and loop_threads() == []
