"""``optimizer=centre``: one evaluation, at the box centre, then done; through the CLI its
record says so."""

from __future__ import annotations

import numpy as np
from vpid_baselines.plugin import Centre, CentreParams

from vpid_bench import Bounds
from vpid_bench.runner import run


class _Recorder:
    """A problem that remembers what it was asked to evaluate."""

    def __init__(self) -> None:
        self.bounds = Bounds(np.array([1.0, -4.0]), np.array([3.0, 0.0]), ("a", "b"))
        self.seen: list[np.ndarray] = []

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        self.seen.append(np.array(X))
        return np.sum(X**2, axis=1)


def test_centre_asks_the_box_centre_once_and_stops():
    problem = _Recorder()
    opt = Centre(CentreParams(ps=20, iterations=50, budget=1020), problem.bounds,
                 np.random.default_rng(0))
    result = run(problem, opt, budget=1020)
    assert result.evaluations == 1 and result.stopped_by == "optimizer"
    assert len(problem.seen) == 1
    assert np.array_equal(problem.seen[0], [[2.0, -2.0]])
    assert np.array_equal(result.x_best, [2.0, -2.0])
