"""The run loop owns the budget, the best-so-far and the trace (vpid_bench.runner)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from vpid_bench.api import (
    Bounds,
    GenerationalOptimizer,
    Optimizer,
    OptimizerContractError,
    OptimizerParams,
    Problem,
)
from vpid_bench.runner import run


class CountingSphere(Problem):
    """sum(x^2) on [-1, 1]^3 that counts every candidate it is asked to evaluate."""

    name = "counting_sphere"

    def __init__(self, nan_rows: tuple[int, ...] = ()) -> None:
        super().__init__(None)
        self.calls = 0
        self.nan_rows = nan_rows
        self._bounds = Bounds(-np.ones(3), np.ones(3), ("a", "b", "c"))

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        self.calls += X.shape[0]
        f = np.sum(X**2, axis=1)
        for r in self.nan_rows:
            if r < f.size:
                f[r] = np.nan
        return f


@dataclass(frozen=True)
class GreedyParams(OptimizerParams):
    batch: int = 1000


class Greedy(Optimizer):
    """Tries to overspend: asks for ``batch`` candidates at every call."""

    Params = GreedyParams

    def __init__(self, params, bounds, rng):
        super().__init__(params, bounds, rng)
        self.told = 0

    def ask(self) -> np.ndarray:
        return self.bounds.sample(self.rng, self.params.batch)

    def tell(self, X, f) -> None:
        self.told += X.shape[0]


class Scripted(Optimizer):
    """Returns the arrays it was given, one per ask."""

    def __init__(self, proposals, bounds):
        super().__init__(OptimizerParams(), bounds, np.random.default_rng(0))
        self.proposals = list(proposals)
        self.received: list[np.ndarray] = []

    def ask(self):
        return self.proposals.pop(0)

    def tell(self, X, f):
        self.received.append(f)

    @property
    def done(self) -> bool:
        return not self.proposals


def test_budget_holds_against_an_optimizer_that_overspends():
    problem = CountingSphere()
    opt = Greedy(GreedyParams(batch=1000), problem.bounds, np.random.default_rng(1))
    result = run(problem, opt, budget=50)
    assert result.evaluations == 50
    assert problem.calls == 50  # the problem never saw a 51st candidate
    assert opt.told == 0  # a cut batch is not told
    assert result.stopped_by == "budget"


def test_budget_exact_over_many_batches():
    problem = CountingSphere()
    opt = Greedy(GreedyParams(batch=7), problem.bounds, np.random.default_rng(1))
    result = run(problem, opt, budget=100)
    assert problem.calls == result.evaluations == 100
    assert result.trace_evaluations == [*range(7, 99, 7), 100]
    assert opt.told == 98  # 14 full batches told, the cut 15th (2 rows) is not


def test_best_and_trace_are_the_loops_own():
    b = Bounds(-np.ones(3), np.ones(3), ("a", "b", "c"))
    X1 = np.array([[0.5, 0.5, 0.5], [0.9, 0.0, 0.0]])
    X2 = np.array([[0.1, 0.0, 0.0], [1.0, 1.0, 1.0]])
    X3 = np.array([[0.3, 0.3, 0.3]])
    opt = Scripted([X1, X2, X3], b)
    result = run(CountingSphere(), opt, budget=100)
    assert result.stopped_by == "optimizer"
    assert result.evaluations == 5
    assert result.trace_evaluations == [2, 4, 5]
    np.testing.assert_allclose(result.trace_best, [0.75, 0.01, 0.01])
    np.testing.assert_array_equal(result.x_best, [0.1, 0.0, 0.0])
    assert result.f_best == pytest.approx(0.01)


def test_nan_objective_becomes_inf_and_never_best():
    b = Bounds(-np.ones(3), np.ones(3), ("a", "b", "c"))
    opt = Scripted([np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]])], b)
    result = run(CountingSphere(nan_rows=(0,)), opt, budget=10)
    assert np.isinf(opt.received[0][0])
    assert result.f_best == pytest.approx(0.75)


def test_minus_inf_from_a_problem_fails_the_run_instead_of_being_best():
    """A problem returning -inf once gave runs recorded ok with f_best = -inf, ranked best."""

    class MinusInf(CountingSphere):
        def evaluate(self, X: np.ndarray) -> np.ndarray:
            f = super().evaluate(X)
            f[-1] = -np.inf
            return f

    b = Bounds(-np.ones(3), np.ones(3), ("a", "b", "c"))
    opt = Scripted([np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]])], b)
    with pytest.raises(ValueError, match=r"returned -inf \(row 1\)"):
        run(MinusInf(), opt, budget=10)


@pytest.mark.parametrize(
    "proposal, fragment",
    [
        (np.zeros((2, 4)), "shape"),
        (np.zeros(3), "shape"),
        (np.zeros((0, 3)), "shape"),
        (np.array([[np.nan, 0.0, 0.0]]), "NaN"),
        (np.array([[1.0 + 1e-12, 0.0, 0.0]]), "outside the bounds"),
        ([[0.0, 0.0, 0.0]], "numpy array"),
    ],
)
def test_contract_violations_are_refused(proposal, fragment):
    b = Bounds(-np.ones(3), np.ones(3), ("a", "b", "c"))
    problem = CountingSphere()
    with pytest.raises(OptimizerContractError, match=fragment):
        run(problem, Scripted([proposal], b), budget=10)
    assert problem.calls == 0


def test_bounds_reject_inverted_box():
    from vpid_bench.api import ConfigError

    with pytest.raises(ConfigError, match="bounds.b"):
        Bounds(np.zeros(2), np.array([1.0, -1.0]), ("a", "b"))


class Shrink(GenerationalOptimizer):
    """Each generation halves every member: records what start/advance received."""

    def next_generation(self):
        return self.pop / 2.0

    def start(self, X, f):
        self.pop, self.seen = X, [f]

    def advance(self, X, f):
        self.pop = X
        self.seen.append(f)


def test_generational_handshake_and_schedule():
    problem = CountingSphere()
    opt = Shrink(OptimizerParams(ps=4, iterations=3), problem.bounds, np.random.default_rng(0))
    X0 = opt.ask()
    np.testing.assert_array_equal(opt.ask(), X0)  # asking again before tell: same rows
    assert np.all(problem.bounds.contains(X0))
    with pytest.raises(ValueError, match="whole population"):
        opt.tell(X0[:2], np.zeros(2))
    result = run(problem, opt, budget=1000)
    assert result.stopped_by == "optimizer" and opt.done and opt.generation == 3
    assert result.evaluations == problem.calls == 4 * (3 + 1)
    np.testing.assert_allclose(opt.pop, X0 / 8.0)
    np.testing.assert_allclose(opt.seen[-1], np.sum((X0 / 8.0) ** 2, axis=1))
