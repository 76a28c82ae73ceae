"""``optimizer=random`` (vpid_baselines): uniform draws from the run's generator, nothing else.

The candidates must be exactly ``lower + U * width`` with ``U`` the generator's next
``(ps, dim)`` uniforms, batch after batch (the algorithm of the former example package, so
records of the same seed are unchanged), and the run's best must be the best of those draws.
"""

from __future__ import annotations

import numpy as np
from vpid_baselines.plugin import RandomSearch, RandomSearchParams

from vpid_bench.api import Bounds, Problem
from vpid_bench.runner import run

BOX = Bounds(np.array([-5.0, 0.0, 10.0]), np.array([5.0, 1e-3, 20.0]), ("a", "b", "c"))


class Shifted(Problem):
    """sum((x - centre)^2 / width^2) over BOX."""

    def __init__(self) -> None:
        super().__init__(None)

    @property
    def bounds(self) -> Bounds:
        return BOX

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        centre = (BOX.lower + BOX.upper) / 2
        return np.sum(((X - centre) / BOX.width) ** 2, axis=1)


def test_random_is_the_first_party_baseline(registry):
    assert registry.optimizers["random"] is RandomSearch
    assert registry.owner("optimizer", "random") == "baselines"


def test_candidates_are_the_generators_uniforms_scaled_to_the_box():
    opt = RandomSearch(RandomSearchParams(ps=7), BOX, np.random.default_rng(42))
    expected = np.random.default_rng(42)
    for _ in range(3):
        X = opt.ask()
        np.testing.assert_array_equal(X, BOX.lower + expected.random((7, 3)) * BOX.width)
        assert np.all(BOX.contains(X))
        opt.tell(X, np.zeros(7))
    assert not opt.done


def test_run_best_is_the_best_of_all_draws_and_the_budget_ends_it():
    problem = Shifted()
    result = run(problem, RandomSearch(RandomSearchParams(ps=5), BOX,
                                       np.random.default_rng(3)), budget=23)
    draws = BOX.lower + np.random.default_rng(3).random((25, 3)) * BOX.width
    draws = draws[:23]  # the last batch is cut to what the budget leaves
    f = problem.evaluate(draws)
    assert result.stopped_by == "budget" and result.evaluations == 23 and result.batches == 5
    np.testing.assert_array_equal(result.x_best, draws[np.argmin(f)])
    assert result.f_best == f.min()
