"""``Optimizer.done`` is settable: an optimizer that writes ``self.done = True`` ends its run,
and a GenerationalOptimizer's schedule still ends it after ``iterations`` generations."""

from __future__ import annotations

import numpy as np
import pytest

from vpid_bench.api import Bounds, GenerationalOptimizer, Optimizer, OptimizerParams, Problem
from vpid_bench.runner import run

BOX = Bounds(-np.ones(2), np.ones(2), ("a", "b"))


class Sphere(Problem):
    """sum(x^2) on [-1, 1]^2, counting the candidates it evaluates."""

    def __init__(self) -> None:
        super().__init__(None)
        self.calls = 0

    @property
    def bounds(self) -> Bounds:
        return BOX

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        self.calls += X.shape[0]
        return np.sum(X * X, axis=1)


class StopAfter(Optimizer):
    """Random batches of ``ps``; sets ``self.done = True`` after ``stop_after`` tells."""

    def __init__(self, params, bounds, rng, stop_after: int) -> None:
        super().__init__(params, bounds, rng)
        self.stop_after, self.tells = stop_after, 0

    def ask(self) -> np.ndarray:
        return self.bounds.sample(self.rng, self.params.ps).clip(-1, 1)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        self.tells += 1
        if self.tells == self.stop_after:
            self.done = True


class Generations(GenerationalOptimizer):
    """Keeps the initial population; may set ``done`` after generation ``stop_at``."""

    def __init__(self, params, bounds, rng, stop_at: int | None = None) -> None:
        super().__init__(params, bounds, rng)
        self.stop_at = stop_at

    def next_generation(self) -> np.ndarray:
        return self.X.copy()

    def start(self, X: np.ndarray, f: np.ndarray) -> None:
        self.X = X

    def advance(self, X: np.ndarray, f: np.ndarray) -> None:
        if self.stop_at is not None and self.generation + 1 == self.stop_at:
            self.done = True


def _rng() -> np.random.Generator:
    return np.random.default_rng(0)


def test_done_defaults_to_false_and_is_settable():
    opt = StopAfter(OptimizerParams(ps=3), BOX, _rng(), stop_after=1)
    assert opt.done is False
    opt.done = 1  # stored as a bool
    assert opt.done is True
    opt.done = False
    assert opt.done is False


def test_an_optimizer_that_sets_done_ends_its_run_before_the_budget():
    problem = Sphere()
    opt = StopAfter(OptimizerParams(ps=3), BOX, _rng(), stop_after=4)
    result = run(problem, opt, budget=300)
    assert result.stopped_by == "optimizer"
    assert result.evaluations == problem.calls == 4 * 3
    assert result.batches == 4 and opt.tells == 4


def test_generational_schedule_still_ends_the_run_after_iterations():
    problem = Sphere()
    opt = Generations(OptimizerParams(ps=5, iterations=3), BOX, _rng())
    result = run(problem, opt, budget=10_000)
    assert result.stopped_by == "optimizer" and opt.generation == 3
    assert result.evaluations == 5 * (3 + 1)
    opt.done = False  # clearing what was set cannot extend the schedule
    assert opt.done is True


@pytest.mark.parametrize("stop_at", [1, 2])
def test_generational_optimizer_can_stop_before_its_schedule(stop_at):
    problem = Sphere()
    opt = Generations(OptimizerParams(ps=5, iterations=10), BOX, _rng(), stop_at=stop_at)
    result = run(problem, opt, budget=10_000)
    assert result.stopped_by == "optimizer" and opt.generation == stop_at
    assert result.evaluations == 5 * (stop_at + 1)
