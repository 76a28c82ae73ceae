"""The previous vehicle kernel (one candidate at a time, scalar Newmark), kept as the baseline of
``benchmarks/bench_vehicle.py`` after the package moved to the structure-of-arrays kernel
(:mod:`vpid_vehicle.kernel`). Copied unchanged from the package at commit 1c529df except for
this docstring; not imported by the package.

The fast path: Newmark-beta for the 4-DOF half-car, compiled with numba.

Same arithmetic as :func:`vpid_vehicle.newmark.newmark` (predictor, one solve with the
precomputed inverse of S = M + gamma dt C + beta dt^2 K, corrector), written out in scalars
for this model's structure: M is diagonal, K[2,3] = C[2,3] = 0, the road acts on the wheel
rows only. Every candidate is independent, so a population is a plain loop.

Importing this module imports numba; it is imported lazily on the first evaluation. The
compiled code is cached on disk (``cache=True``), so later processes load it instead of
compiling (about a second versus several).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def _inverse_sym4(S: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Inverse of a 4x4 matrix by Gauss-Jordan without pivoting (S is SPD for a physical
    candidate; a non-positive pivot gives inf/NaN, caught by the caller)."""
    A = S.copy()
    for i in range(4):
        for j in range(4):
            out[i, j] = 1.0 if i == j else 0.0
    for i in range(4):
        p = 1.0 / A[i, i]
        for j in range(4):
            A[i, j] *= p
            out[i, j] *= p
        for r in range(4):
            if r != i:
                f = A[r, i]
                if f != 0.0:
                    for j in range(4):
                        A[r, j] -= f * A[i, j]
                        out[r, j] -= f * out[i, j]


@njit(cache=True, error_model="numpy")
def _candidate(
    x: np.ndarray,
    L: float,
    kt1: float,
    kt2: float,
    y1: np.ndarray,
    y2: np.ndarray,
    dt: float,
    gamma: float,
    beta: float,
    z: np.ndarray,
    S: np.ndarray,
    Si: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Fill ``z[0, k]`` and ``z[1, k]`` with z1'' and z2'' (m/s^2) at ``t_k`` for the
    candidate ``x`` (m, I, m1, m2, k1, k2, c1, c2, a1). ``y1``, ``y2``: tyre inputs (m) as
    sampled for the integrator; ``S``, ``Si``: 4x4 scratch. Non-physical: inf or NaN."""
    N = y1.shape[0]
    ca = dt * dt * (0.5 - beta)
    cv = dt * (1.0 - gamma)
    bd = beta * dt * dt
    gd = gamma * dt
    m, I, m1, m2 = x[0], x[1], x[2], x[3]
    k1, k2, c1, c2, a1 = x[4], x[5], x[6], x[7], x[8]
    a2 = L - a1
    K00 = k1 + k2
    K01 = a2 * k2 - a1 * k1
    K02 = -k1
    K03 = -k2
    K11 = k1 * a1 * a1 + k2 * a2 * a2
    K12 = a1 * k1
    K13 = -a2 * k2
    K22 = k1 + kt1
    K33 = k2 + kt2
    C00 = c1 + c2
    C01 = a2 * c2 - a1 * c1
    C02 = -c1
    C03 = -c2
    C11 = c1 * a1 * a1 + c2 * a2 * a2
    C12 = a1 * c1
    C13 = -a2 * c2
    C22 = c1
    C33 = c2
    S[0, 0] = m + gd * C00 + bd * K00
    S[0, 1] = gd * C01 + bd * K01
    S[0, 2] = gd * C02 + bd * K02
    S[0, 3] = gd * C03 + bd * K03
    S[1, 1] = I + gd * C11 + bd * K11
    S[1, 2] = gd * C12 + bd * K12
    S[1, 3] = gd * C13 + bd * K13
    S[2, 2] = m1 + gd * C22 + bd * K22
    S[2, 3] = 0.0
    S[3, 3] = m2 + gd * C33 + bd * K33
    for r in range(4):
        for c in range(r):
            S[r, c] = S[c, r]
    _inverse_sym4(S, Si)
    s00, s01, s02, s03 = Si[0, 0], Si[0, 1], Si[0, 2], Si[0, 3]
    s10, s11, s12, s13 = Si[1, 0], Si[1, 1], Si[1, 2], Si[1, 3]
    s20, s21, s22, s23 = Si[2, 0], Si[2, 1], Si[2, 2], Si[2, 3]
    s30, s31, s32, s33 = Si[3, 0], Si[3, 1], Si[3, 2], Si[3, 3]
    d0 = d1 = d2 = d3 = 0.0
    v0 = v1 = v2 = v3 = 0.0
    a0 = 0.0
    a1_ = 0.0
    a2_ = kt1 * y1[0] / m1
    a3 = kt2 * y2[0] / m2
    z[0, 0] = a0 - a1 * a1_
    z[1, 0] = a0 + a2 * a1_
    for k in range(1, N):
        p0 = d0 + dt * v0 + ca * a0
        p1 = d1 + dt * v1 + ca * a1_
        p2 = d2 + dt * v2 + ca * a2_
        p3 = d3 + dt * v3 + ca * a3
        q0 = v0 + cv * a0
        q1 = v1 + cv * a1_
        q2 = v2 + cv * a2_
        q3 = v3 + cv * a3
        r0 = -(K00 * p0 + K01 * p1 + K02 * p2 + K03 * p3) - (
            C00 * q0 + C01 * q1 + C02 * q2 + C03 * q3)
        r1 = -(K01 * p0 + K11 * p1 + K12 * p2 + K13 * p3) - (
            C01 * q0 + C11 * q1 + C12 * q2 + C13 * q3)
        r2 = kt1 * y1[k] - (K02 * p0 + K12 * p1 + K22 * p2) - (
            C02 * q0 + C12 * q1 + C22 * q2)
        r3 = kt2 * y2[k] - (K03 * p0 + K13 * p1 + K33 * p3) - (
            C03 * q0 + C13 * q1 + C33 * q3)
        a0 = s00 * r0 + s01 * r1 + s02 * r2 + s03 * r3
        a1_ = s10 * r0 + s11 * r1 + s12 * r2 + s13 * r3
        a2_ = s20 * r0 + s21 * r1 + s22 * r2 + s23 * r3
        a3 = s30 * r0 + s31 * r1 + s32 * r2 + s33 * r3
        d0 = p0 + bd * a0
        d1 = p1 + bd * a1_
        d2 = p2 + bd * a2_
        d3 = p3 + bd * a3
        v0 = q0 + gd * a0
        v1 = q1 + gd * a1_
        v2 = q2 + gd * a2_
        v3 = q3 + gd * a3
        z[0, k] = a0 - a1 * a1_
        z[1, k] = a0 + a2 * a1_


@njit(cache=True, error_model="numpy")
def simulate(
    X: np.ndarray, L: float, kt1: float, kt2: float, y1: np.ndarray, y2: np.ndarray,
    dt: float, gamma: float, beta: float, out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """``out[j]`` = z1'', z2'' of row ``j`` of ``X``, shape ``(n, 2, N)``."""
    S = np.empty((4, 4))
    Si = np.empty((4, 4))
    for j in range(X.shape[0]):
        _candidate(X[j], L, kt1, kt2, y1, y2, dt, gamma, beta, out[j], S, Si)


@njit(cache=True, error_model="numpy")
def objective(
    X: np.ndarray, L: float, kt1: float, kt2: float, y1: np.ndarray, y2: np.ndarray,
    dt: float, gamma: float, beta: float, ref: np.ndarray, f: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """``f[j]`` = Eq. (3) for row ``j`` of ``X`` against ``ref`` (2, N); inf for a
    non-physical candidate (mass <= 0, negative stiffness or damping, a1 outside (0, L),
    non-finite values) or a non-finite response."""
    N = y1.shape[0]
    den = np.sqrt(np.sum(ref[0] ** 2)) + np.sqrt(np.sum(ref[1] ** 2))
    z = np.empty((2, N))
    S = np.empty((4, 4))
    Si = np.empty((4, 4))
    for j in range(X.shape[0]):
        x = X[j]
        ok = x[8] > 0.0 and x[8] < L
        for i in range(9):
            if not np.isfinite(x[i]) or (i < 4 and x[i] <= 0.0) or x[i] < 0.0:
                ok = False
        if not ok:
            f[j] = np.inf
            continue
        _candidate(x, L, kt1, kt2, y1, y2, dt, gamma, beta, z, S, Si)
        e1 = 0.0
        e2 = 0.0
        for k in range(N):
            u = ref[0, k] - z[0, k]
            w = ref[1, k] - z[1, k]
            e1 += u * u
            e2 += w * w
        fj = (np.sqrt(e1) + np.sqrt(e2)) / den
        f[j] = fj if np.isfinite(fj) else np.inf


def _inputs(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fresh writable C-contiguous float64 copies, so every call has the same numba
    signature (a read-only array would be a new type and trigger a second compilation)."""
    X = np.array(np.atleast_2d(X), dtype=np.float64, order="C")
    return X, np.array(y[:, 0], dtype=np.float64), np.array(y[:, 1], dtype=np.float64)


def evaluate(
    X: np.ndarray, L: float, kt1: float, kt2: float, y: np.ndarray, dt: float, gamma: float,
    beta: float, ref: np.ndarray,
) -> np.ndarray:
    """Eq. (3) for every row of ``X`` against the reference ``ref`` (2, N), shape ``(n,)``."""
    X, y1, y2 = _inputs(X, y)
    f = np.empty(X.shape[0])
    objective(X, float(L), float(kt1), float(kt2), y1, y2, float(dt), float(gamma), float(beta),
              np.array(ref, dtype=np.float64, order="C"), f)
    return f


def body_accelerations(
    X: np.ndarray, L: float, kt1: float, kt2: float, y: np.ndarray, dt: float, gamma: float,
    beta: float,
) -> np.ndarray:
    """z1'' and z2'' (m/s^2) of every row of ``X``, shape ``(n, 2, N)``; ``y`` is ``(N, 2)``."""
    X, y1, y2 = _inputs(X, y)
    out = np.empty((X.shape[0], 2, y1.shape[0]))
    simulate(X, float(L), float(kt1), float(kt2), y1, y2, float(dt), float(gamma), float(beta),
             out)
    return out
