"""The plain Newmark integrator against analytic single-DOF solutions, and its invariants."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_vehicle.config import PARAM_NAMES, VehicleConfig
from vpid_vehicle.model import KnownConstants, matrices
from vpid_vehicle.newmark import newmark
from vpid_vehicle.road import Bump, sample, time_grid

M1 = 2.0  # kg
W = 2 * np.pi * 3.0  # rad/s (3 Hz)
K1 = M1 * W**2  # N/m


def sdof(c: float, dt: float, t_end: float, F=None, d0=0.0, v0=0.0, gamma=0.5, beta=0.25):
    """One-DOF Newmark; returns t, d, v."""
    t = time_grid(t_end, dt)
    F = np.zeros((t.size, 1)) if F is None else np.asarray(F).reshape(t.size, 1)
    d, v, _ = newmark(np.array([[[M1]]]), np.array([[[c]]]), np.array([[[K1]]]), F, dt,
                      gamma, beta, d0=np.array([[d0]]), v0=np.array([[v0]]))
    return t, d[:, 0, 0], v[:, 0, 0]


def step_response(t: np.ndarray, zeta: float, u0: float) -> tuple[np.ndarray, np.ndarray]:
    """x, x' of m x'' + c x' + k x = k u0 H(t) from rest (underdamped)."""
    wd = W * np.sqrt(1 - zeta**2)
    e = np.exp(-zeta * W * t)
    x = u0 * (1 - e * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t)))
    v = u0 * e * (W / np.sqrt(1 - zeta**2)) * np.sin(wd * t)
    return x, v


def order(errors: list[float]) -> np.ndarray:
    """Observed orders for dt halved at each step."""
    return np.log2(np.array(errors[:-1]) / np.array(errors[1:]))


def test_undamped_free_vibration_second_order():
    errors = []
    for dt in (2e-3, 1e-3, 5e-4):
        t, d, _ = sdof(0.0, dt, 1.0, d0=0.01)
        errors.append(np.abs(d - 0.01 * np.cos(W * t)).max() / 0.01)
    assert errors[1] < 2e-3  # phase error (w dt)^2 / 12 * w t ~ 6e-4 at 1 ms
    np.testing.assert_allclose(order(errors), 2.0, atol=0.05)


def test_damped_step_response():
    zeta = 0.1
    c = 2 * zeta * W * M1
    errors = []
    for dt in (2e-3, 1e-3, 5e-4):
        t, d, v = sdof(c, dt, 1.0, F=np.full(time_grid(1.0, dt).size, K1 * 0.04))
        x, xd = step_response(t, zeta, 0.04)
        errors.append(max(np.abs(d - x).max() / 0.04, np.abs(v - xd).max() / (0.04 * W)))
    assert errors[1] < 1e-3
    np.testing.assert_allclose(order(errors), 2.0, atol=0.1)


def fitted_order(dts, errors) -> float:
    """Least-squares slope of log(error) against log(dt)."""
    return float(np.polyfit(np.log(dts), np.log(errors), 1)[0])


@pytest.mark.parametrize(
    ("mode", "t_off", "expected_order", "tol"),
    [("point", 0.012, 1.0, 0.1), ("average", 0.012, 2.0, 0.1), ("average", 0.0123, 2.0, 0.3)],
)
def test_pulse_input_order_per_sampling(mode, t_off, expected_order, tol):
    """A rectangular pulse of 12 ms (edge on every grid) or 12.3 ms (edge between grid
    points, at a different fraction of a step for each dt, hence the wider tolerance):
    point sampling converges at first order, exact step means at second order."""
    zeta, h = 0.1, 0.04
    c = 2 * zeta * W * M1
    bump = Bump(h=h, front_on=0.0, front_off=t_off, rear_on=10.0, rear_off=11.0)
    dts = [1e-3, 5e-4, 2.5e-4, 1.25e-4]
    errors = []
    for dt in dts:
        t = time_grid(0.5, dt)
        y = sample(bump, t, mode)[:, 0]
        _, d, _ = sdof(c, dt, 0.5, F=K1 * y)
        x_on, _ = step_response(t, zeta, h)
        x_off, _ = step_response(np.clip(t - t_off, 0, None), zeta, h)
        errors.append(np.abs(d - (x_on - x_off)).max() / h)
    assert fitted_order(dts, errors) == pytest.approx(expected_order, abs=tol)


def test_energy_conserved_without_damping():
    """Average acceleration conserves 1/2 v'Mv + 1/2 d'Kd exactly (round-off) for the
    undamped, unforced 4-DOF model; gamma > 1/2 dissipates (the check can fail)."""
    p = VehicleConfig().vehicle
    x = np.array([[getattr(p, n) for n in PARAM_NAMES]])
    M, _, K = matrices(x, KnownConstants(p.L, p.kt1, p.kt2))
    C = np.zeros_like(K)
    d0 = np.array([[0.01, 0.005, -0.002, 0.003]])
    F = np.zeros((3000, 4))

    def energy(gamma: float, beta: float) -> np.ndarray:
        d, v, _ = newmark(M, C, K, F, 1e-3, gamma, beta, d0=d0)
        return 0.5 * (np.einsum("ki,ij,kj->k", v[:, 0], M[0], v[:, 0])
                      + np.einsum("ki,ij,kj->k", d[:, 0], K[0], d[:, 0]))

    E = energy(0.5, 0.25)
    assert np.abs(E / E[0] - 1).max() < 1e-12
    E_damped = energy(0.6, 0.3025)
    assert E_damped[-1] < 0.9 * E_damped[0]
