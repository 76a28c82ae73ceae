"""The matrices of Eq. (2): symmetry, the Lagrangian form, statics and modal frequencies."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from vpid_vehicle.config import PARAM_NAMES, VehicleConfig
from vpid_vehicle.model import (
    KnownConstants,
    lagrangian_matrices,
    matrices,
    physical,
    response_rows,
    tyre_input,
)

P = VehicleConfig().vehicle
KNOWN = KnownConstants(P.L, P.kt1, P.kt2)
X_TRUE = np.array([[getattr(P, n) for n in PARAM_NAMES]])
G = 9.81  # m/s^2


@pytest.fixture()
def population() -> np.ndarray:
    rng = np.random.default_rng(1)
    return X_TRUE * rng.uniform(0.5, 1.5, (6, 9))


def test_matrices_are_symmetric_and_definite(population):
    M, C, K = matrices(population, KNOWN)
    for A in (M, C, K):
        np.testing.assert_array_equal(A, np.swapaxes(A, 1, 2))
    assert np.all(np.linalg.eigvalsh(K) > 0)  # tyres anchor every mode
    assert np.all(np.linalg.eigvalsh(C) > -1e-9 * np.abs(C).max())  # PSD (tyres undamped)


def test_erratum_entry_is_minus_a2_k2():
    _, _, K = matrices(X_TRUE, KNOWN)
    assert K[0, 3, 1] == pytest.approx(-(P.L - P.a1) * P.k2, rel=1e-15)


def test_c_and_k_equal_jt_d_j(population):
    _, C, K = matrices(population, KNOWN)
    C2, K2 = lagrangian_matrices(population, KNOWN)
    np.testing.assert_allclose(C, C2, rtol=0, atol=1e-12 * np.abs(C).max())
    np.testing.assert_allclose(K, K2, rtol=0, atol=1e-12 * np.abs(K).max())


def test_uniform_road_lift_lifts_everything_equally():
    """Both tyres on a plateau of height h: the static solution K^-1 F is a rigid lift."""
    h = 0.04
    _, _, K = matrices(X_TRUE, KNOWN)
    F = tyre_input(KNOWN) @ np.array([h, h])
    np.testing.assert_allclose(np.linalg.solve(K[0], F), [h, 0.0, h, h], rtol=0, atol=1e-15)


def test_static_sag_under_gravity_matches_hand_statics():
    """Weight: the body load splits a2/L front and a1/L rear; each spring compresses by
    force / stiffness. K^-1 F must give the same displacements (to 1e-12 relative)."""
    a1, a2 = P.a1, P.L - P.a1
    f_front, f_rear = P.m * G * a2 / P.L, P.m * G * a1 / P.L
    x1 = -(f_front + P.m1 * G) / P.kt1
    x2 = -(f_rear + P.m2 * G) / P.kt2
    z1 = x1 - f_front / P.k1  # body point above the front axle
    z2 = x2 - f_rear / P.k2
    expected = [(a2 * z1 + a1 * z2) / P.L, (z2 - z1) / P.L, x1, x2]
    _, _, K = matrices(X_TRUE, KNOWN)
    F = -G * np.array([P.m, 0.0, P.m1, P.m2])
    np.testing.assert_allclose(np.linalg.solve(K[0], F), expected, rtol=1e-12)
    R = response_rows(X_TRUE, KNOWN)[0]
    np.testing.assert_allclose(R @ expected, [z1, z2], rtol=1e-12)


def test_undamped_modal_frequencies():
    """scipy.linalg.eigh(K, M) at the true values: about 1.13, 1.37, 8.94, 12.3 Hz."""
    M, _, K = matrices(X_TRUE, KNOWN)
    f = np.sqrt(scipy.linalg.eigh(K[0], M[0], eigvals_only=True)) / (2 * np.pi)
    np.testing.assert_allclose(f, [1.13, 1.37, 8.94, 12.3], rtol=5e-3)


def test_physical_flags_bad_candidates():
    X = np.repeat(X_TRUE, 5, axis=0)
    X[1, 0] = 0.0  # massless body
    X[2, 8] = P.L  # a1 = L (a2 = 0)
    X[3, 8] = -0.1
    X[4, 6] = np.nan
    assert physical(X, KNOWN).tolist() == [True, False, False, False, False]
