"""The optimum polish's batched forward-difference Jacobian (vpid_bench.analysis.optimum)."""

from __future__ import annotations

import numpy as np

from vpid_bench.analysis import optimum
from vpid_bench.build import build_problem


def test_forward_jacobian_matches_the_analytic_one_inside_and_at_the_box(registry):
    p = build_problem(registry, {"name": "functions", "function": "rosenbrock", "dim": 3})
    scale, w = np.ones(3), np.ones(4)
    lo, hi = p.bounds.lower, p.bounds.upper

    def analytic(x):  # r = [10 (x2 - x1^2), 10 (x3 - x2^2), 1 - x1, 1 - x2]
        return np.array([[-20 * x[0], 10, 0], [0, -20 * x[1], 10], [-1, 0, 0], [0, -1, 0]])

    for z in (np.array([0.3, -1.2, 2.0]), hi.copy()):  # at the upper bound: backward steps
        J = optimum._forward_jacobian(p, z, scale, w, lo, hi)
        np.testing.assert_allclose(J, analytic(z), rtol=0, atol=1e-5 * np.abs(analytic(z)).max())


def test_polish_reaches_the_minimum(registry):
    p = build_problem(registry, {"name": "functions", "function": "rosenbrock", "dim": 4})
    x, f = optimum.polish(p, np.array([0.5, 0.4, 0.3, 0.2]))
    np.testing.assert_allclose(x, np.ones(4), atol=1e-6)
    assert f < 1e-12
