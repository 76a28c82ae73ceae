"""lsq: the sum-of-norms model, the bounded step, convergence to analytic solutions, and the
IRLS fixed point as a stationary point of the sum of norms (checked independently)."""

from __future__ import annotations

import numpy as np
import pytest
from peers_helpers import LinearLSQ
from scipy.optimize import approx_fprime, minimize
from vpid_peers.coordinates import Coordinates
from vpid_peers.lsq import LeastSquares, LSQParams
from vpid_peers.solver import Solver, SolverSettings
from vpid_peers.sumofnorms import LocalModel, box_step, gradient, sum_of_norms

from vpid_bench.api import Bounds
from vpid_bench.runner import run


def test_local_model_value_and_irls_gradient_match_the_sum_of_norms():
    rng = np.random.default_rng(0)
    A, b = rng.normal(size=(7, 3)), rng.normal(size=7)
    groups = np.array([0, 0, 0, 1, 1, 2, 2])

    def fun(x):
        return sum_of_norms((b - A @ x)[None], groups, 3)[0]

    x = rng.normal(size=3)
    r, J = b - A @ x, -A  # linear: the model is exact
    model = LocalModel(r, J, groups, 3)
    p = rng.normal(size=3)
    assert model.value(p) == pytest.approx(fun(x + p), rel=1e-12)
    _, g = model.irls_system(np.zeros(3))
    numeric = approx_fprime(x, fun, 1e-7)
    np.testing.assert_allclose(g, numeric, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(gradient(r, J, groups, 3), numeric, rtol=1e-5, atol=1e-6)


def test_box_step_is_the_newton_step_inside_and_stays_in_the_box():
    H = np.array([[2.0, 0.5], [0.5, 1.0]])
    g = np.array([-1.0, 0.3])
    free = box_step(H, g, np.zeros(2), -10 * np.ones(2), 10 * np.ones(2))
    np.testing.assert_allclose(free, np.linalg.solve(H, -g))
    # a face cuts x0 (unconstrained 0.7): fixed at 0.2, x1 then minimises with x0 fixed
    p = box_step(H, g, np.zeros(2), np.array([-1.0, -1.0]), np.array([0.2, 1.0]))
    assert p[0] == 0.2 and p[1] == pytest.approx((-g[1] - H[1, 0] * 0.2) / H[1, 1])


def test_box_step_solves_bounded_quadratics_like_scipy_lsq_linear():
    """Random convex quadratics over boxes around 0: the active-set step equals scipy's
    bounded least squares on the same quadratic (M = L L^T: 1/2 ||L^T p + L^-1 g||^2)."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(3)
    for _ in range(20):
        B = rng.normal(size=(6, 6))
        M, g = B @ B.T + 0.1 * np.eye(6), rng.normal(size=6) * 3
        lower, upper = -rng.uniform(0, 0.5, 6), rng.uniform(0, 0.5, 6)
        lower[0] = 0.0  # a coordinate on its face
        L = np.linalg.cholesky(M)
        expected = lsq_linear(L.T, -np.linalg.solve(L, g), bounds=(lower, upper),
                              method="bvls", tol=1e-14).x
        np.testing.assert_allclose(box_step(M, g, np.zeros(6), lower, upper), expected,
                                   atol=1e-10)


def _linear(m=12, d=4, seed=0, groups=None):
    rng = np.random.default_rng(seed)
    return LinearLSQ(rng.normal(size=(m, d)), rng.normal(size=m), -5.0, 5.0, groups)


def test_lsq_reaches_the_analytic_linear_least_squares_solution():
    for seed in range(3):
        problem = _linear(seed=seed)
        x_ls = np.linalg.lstsq(problem.A, problem.b, rcond=None)[0]
        assert problem.bounds.contains(x_ls).all()
        opt = LeastSquares(LSQParams(ftol=1e-15), problem.bounds, np.random.default_rng(seed))
        result = run(problem, opt, budget=60)
        np.testing.assert_allclose(result.x_best, x_ls, rtol=1e-6, atol=1e-8)


def test_lsq_respects_bounds_and_finds_the_bounded_solution():
    """Box [0, 0.1]^4 excludes the unconstrained solution: compare with scipy's lsq_linear."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(4)
    problem = LinearLSQ(rng.normal(size=(10, 4)), rng.normal(size=10), 0.0, 0.1)
    expected = lsq_linear(problem.A, problem.b, bounds=(0.0, 0.1), tol=1e-12).x
    result = run(problem, LeastSquares(LSQParams(), problem.bounds, np.random.default_rng(1)), 200)
    assert problem.bounds.contains(result.x_best).all()
    np.testing.assert_allclose(result.x_best, expected, atol=1e-6)


class ExpDecays(LinearLSQ):
    """Two channels ``y_c(t) = a_c exp(-k t)`` of very different noise, parameters
    ``(a_1, a_2, k)``: sum of channel norms and sum of squares have different minimisers."""

    def __init__(self):
        t = np.linspace(0, 3, 40)
        rng = np.random.default_rng(7)
        self.t = t
        y1 = 2.0 * np.exp(-1.3 * t) + 0.01 * rng.normal(size=t.size)
        y2 = 1.0 * np.exp(-1.3 * t) + 0.3 * rng.normal(size=t.size)
        self.y = np.concatenate([y1, y2])
        self.groups = np.repeat([0, 1], t.size)
        self._bounds = Bounds(np.array([0.5, 0.2, 0.3]), np.array([4.0, 3.0, 3.0]),
                              ("a1", "a2", "k"))
        self.evaluated = 0

    def residuals(self, X):
        X = np.atleast_2d(X)
        e = np.exp(-X[:, 2:3] * self.t[None])
        return self.y[None] - np.hstack([X[:, 0:1] * e, X[:, 1:2] * e])


def test_irls_fixed_point_is_a_stationary_point_of_the_sum_of_norms():
    problem = ExpDecays()
    coords = Coordinates(problem.bounds, "log")

    def ev(X):
        R = problem.residuals(X)
        return sum_of_norms(R, problem.groups, 2), R

    solver = Solver(ev, coords, problem.groups, SolverSettings(broyden=False, ftol=1e-15))
    d = solver.descend(coords.to_u(np.array([3.0, 2.5, 0.6])))
    x = coords.to_x(d.u)

    def norms(z):
        return sum_of_norms(problem.residuals(z), problem.groups, 2)[0]

    def squares(z):
        return float(np.sum(problem.residuals(z) ** 2))

    away = np.abs(approx_fprime(x * 1.05, norms, 1e-7)).max()  # the slope 5 % away
    assert np.abs(approx_fprime(x, norms, 1e-8)).max() < 1e-5 * away
    # not the least-squares point: the sum of squares still has a clear slope here
    slope = np.abs(approx_fprime(x, squares, 1e-8)).max()
    assert slope > 1e-2 * np.abs(approx_fprime(x * 1.05, squares, 1e-7)).max()
    # an independent minimiser of the sum of norms (Nelder-Mead, no residuals): no lower value
    nm = minimize(norms, x * 1.1, method="Nelder-Mead",
                  options={"xatol": 1e-10, "fatol": 1e-14, "maxiter": 20000})
    assert norms(x) <= nm.fun * (1 + 1e-9)
    np.testing.assert_allclose(x, nm.x, rtol=1e-4)


def test_jacobian_batches_and_random_starts(vehicle):
    """The first batch is the start and its n neighbours (n + 1 rows); later batches are one
    trial row or an n-row Jacobian; starts are uniform, not the box centre (the truth)."""
    sizes, firsts, first_rows = [], [], []

    class Spy:
        name, bounds = vehicle.name, vehicle.bounds
        has_residuals = True

        def residual_groups(self):
            return vehicle.residual_groups()

        def evaluate_with_residuals(self, X):
            if not sizes:
                first_rows.append(X[0].copy())
            sizes.append(len(X))
            return vehicle.evaluate_with_residuals(X)

    for seed in range(3):
        sizes.clear()
        first_rows.clear()
        opt = LeastSquares(LSQParams(), vehicle.bounds, np.random.default_rng(seed))
        run(Spy(), opt, budget=120)
        assert sizes[0] == 10 and set(sizes[1:-1]) <= {1, 9, 10} and sum(sizes) == 120
        firsts.append(first_rows[0])
    centre = 0.5 * (vehicle.bounds.lower + vehicle.bounds.upper)
    for x in firsts:
        assert vehicle.bounds.contains(x).all()
        assert np.max(np.abs(x - centre) / vehicle.bounds.width) > 0.05
    assert len({tuple(x) for x in firsts}) == 3


def test_lsq_reaches_the_vehicle_optimum_within_the_paper_budget(vehicle):
    """One record, one random start: within 300 evaluations lsq is within 1e-6 (relative) of
    the optimum polished from the truth."""
    p = vehicle
    coords = Coordinates(p.bounds, "log")
    polish = Solver(p.evaluate_with_residuals, coords, p.residual_groups(),
                    SolverSettings(broyden=False, ftol=1e-15))
    d = polish.descend(coords.to_u(p.x_true))
    f_opt = float(p.evaluate(coords.to_x(d.u)[None])[0])
    assert f_opt < float(p.evaluate(p.x_true[None])[0])  # noise: the optimum is not the truth
    result = run(p, LeastSquares(LSQParams(), p.bounds, np.random.default_rng(0)), budget=300)
    assert result.f_best <= f_opt * (1 + 1e-6)
