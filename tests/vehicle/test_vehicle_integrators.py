"""The 4-DOF integrators against each other: exact solver, plain Newmark, compiled kernel."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_vehicle import exact, kernel, newmark
from vpid_vehicle.config import PARAM_NAMES, VehicleConfig, window
from vpid_vehicle.model import KnownConstants
from vpid_vehicle.road import Bump, sample, time_grid

CFG = VehicleConfig()
P = CFG.vehicle
KNOWN = KnownConstants(P.L, P.kt1, P.kt2)
BUMP = Bump.from_geometry(CFG.bump.V, CFG.bump.h, CFG.bump.w, P.L)
T = window(CFG)
X_TRUE = np.array([[getattr(P, n) for n in PARAM_NAMES]])


def rel_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.fixture(scope="module")
def errors_by_mode() -> dict[str, list[float]]:
    out: dict[str, list[float]] = {"point": [], "average": []}
    for dt in (2e-3, 1e-3, 5e-4):
        t = time_grid(T, dt)
        ref = exact.body_accelerations(X_TRUE, KNOWN, BUMP, t)
        for mode in out:
            y = sample(BUMP, t, mode)
            out[mode].append(rel_error(newmark.body_accelerations(X_TRUE, KNOWN, y, dt, .5, .25),
                                       ref))
    return out


@pytest.mark.parametrize(("mode", "expected", "at_1ms"), [("point", 1.0, 0.05),
                                                          ("average", 2.0, 1e-3)])
def test_newmark_converges_to_exact(errors_by_mode, mode, expected, at_1ms):
    """Relative 2-norm error of z1'', z2'' over the paper's window: first order with point
    sampling (3.4 % at 1 ms), second order with step means (below 0.1 % at 1 ms)."""
    e = errors_by_mode[mode]
    orders = np.log2(np.array(e[:-1]) / np.array(e[1:]))
    np.testing.assert_allclose(orders, expected, atol=0.1)
    assert e[1] < at_1ms


def test_exact_solver_does_not_depend_on_its_grid():
    """Exact at 1 ms equals exact at 0.5 ms on the shared samples (the bump edges split the
    steps differently on each grid), to 1e-9 relative."""
    t1, t2 = time_grid(T, 1e-3), time_grid(T, 5e-4)
    a = exact.body_accelerations(X_TRUE, KNOWN, BUMP, t1)
    b = exact.body_accelerations(X_TRUE, KNOWN, BUMP, t2)[:, :, ::2][:, :, : t1.size]
    assert rel_error(a, b) < 1e-9


@pytest.mark.parametrize(("mode", "gamma", "beta"), [("point", 0.5, 0.25),
                                                     ("average", 0.5, 0.25),
                                                     ("point", 0.6, 0.3025)])
def test_kernel_equals_plain_newmark(mode, gamma, beta):
    """The compiled fast path agrees with the plain numpy Newmark to 1e-10 (relative to the
    largest acceleration), over a population spread across the search box."""
    X = X_TRUE * np.random.default_rng(3).uniform(0.5, 1.5, (8, 9))
    t = time_grid(T + 0.3, 1e-3)
    y = sample(BUMP, t, mode, gamma)
    fast = kernel.Setup(P.L, P.kt1, P.kt2, y, 1e-3, gamma, beta).responses(X)
    plain = newmark.body_accelerations(X, KNOWN, y, 1e-3, gamma, beta)
    assert np.abs(fast - plain).max() <= 1e-10 * np.abs(plain).max()


def test_fused_kernel_objective_equals_numpy_objective():
    """The compiled Eq. (3) (simulation and norms fused) equals Eq. (3) computed in numpy on
    the plain Newmark's responses, to 1e-10 relative; non-physical rows give inf."""
    from vpid_vehicle.objective import objective

    X = X_TRUE * np.random.default_rng(4).uniform(0.5, 1.5, (6, 9))
    X[4, 0] = -1.0
    X[5, 8] = P.L + 0.1
    t = time_grid(T, 1e-3)
    y = sample(BUMP, t, "point")
    ref = newmark.body_accelerations(X_TRUE, KNOWN, y, 1e-3, 0.5, 0.25)[0] * 1.01
    fused = kernel.Setup(P.L, P.kt1, P.kt2, y, 1e-3, 0.5, 0.25).objective(X, ref)
    plain = objective(newmark.body_accelerations(X[:4], KNOWN, y, 1e-3, 0.5, 0.25), ref)
    np.testing.assert_allclose(fused[:4], plain, rtol=1e-10, atol=0)
    assert np.all(np.isinf(fused[4:]))
