"""The half-car model of Gökdağ (2014), Eq. (2) and (5), for a whole population at once:
``q = [x, theta, x1, x2]`` (bounce m, pitch rad with the rear up, front and rear wheel hop
m), candidates rows ``[m, I, m1, m2, k1, k2, c1, c2, a1]`` (Eq. 4), ``L``, ``kt1``, ``kt2``
known, ``a2 = L - a1``. :func:`matrices` is Eq. (2) with the erratum K[3,1] = -a2 k2 fixed;
:func:`lagrangian_matrices` derives C and K independently, for the tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class KnownConstants:
    """What is known and not identified: wheelbase ``L`` (m), tyre stiffnesses (N/m)."""

    L: float
    kt1: float
    kt2: float


def _columns(X: np.ndarray) -> tuple[np.ndarray, ...]:
    X = np.atleast_2d(np.asarray(X, dtype=float))
    if X.shape[1] != 9:
        raise ValueError(f"candidates must have 9 columns (m, I, m1, m2, k1, k2, c1, c2, a1), "
                         f"got shape {X.shape}")
    return tuple(X[:, j] for j in range(9))


def matrices(X: np.ndarray, known: KnownConstants) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, C, K of Eq. (2), each of shape ``(n, 4, 4)`` (SI units)."""
    m, I, m1, m2, k1, k2, c1, c2, a1 = _columns(X)
    a2 = known.L - a1
    n = m.size
    M = np.zeros((n, 4, 4))
    M[:, 0, 0], M[:, 1, 1], M[:, 2, 2], M[:, 3, 3] = m, I, m1, m2

    def suspension(s1: np.ndarray, s2: np.ndarray, t1: float, t2: float) -> np.ndarray:
        A = np.zeros((n, 4, 4))
        A[:, 0, 0] = s1 + s2
        A[:, 0, 1] = A[:, 1, 0] = a2 * s2 - a1 * s1
        A[:, 0, 2] = A[:, 2, 0] = -s1
        A[:, 0, 3] = A[:, 3, 0] = -s2
        A[:, 1, 1] = s1 * a1**2 + s2 * a2**2
        A[:, 1, 2] = A[:, 2, 1] = a1 * s1
        A[:, 1, 3] = A[:, 3, 1] = -a2 * s2  # printed -a3 k2 in Eq. (2c): erratum
        A[:, 2, 2] = s1 + t1
        A[:, 3, 3] = s2 + t2
        return A

    C = suspension(c1, c2, 0.0, 0.0)
    K = suspension(k1, k2, known.kt1, known.kt2)
    return M, C, K


def lagrangian_matrices(X: np.ndarray, known: KnownConstants) -> tuple[np.ndarray, np.ndarray]:
    """C and K from the Lagrangian: potential 1/2 e^T D_k e and Rayleigh dissipation
    1/2 e'^T D_c e' give K = J^T D_k J and C = J^T D_c J (no tyre damping), ``e = J q``
    the front and rear suspension (wheel minus body point) and tyre (wheel minus road)."""
    m, I, m1, m2, k1, k2, c1, c2, a1 = _columns(X)
    J = np.zeros((m.size, 4, 4))
    J[:, 0, 0], J[:, 0, 1], J[:, 0, 2] = -1.0, a1, 1.0  # x1 - (x - a1 theta)
    J[:, 1, 0], J[:, 1, 1], J[:, 1, 3] = -1.0, -(known.L - a1), 1.0  # x2 - (x + a2 theta)
    J[:, 2, 2] = J[:, 3, 3] = 1.0  # x1 - y1, x2 - y2
    zero = np.zeros_like(m)
    Dk = np.stack([k1, k2, np.full_like(m, known.kt1), np.full_like(m, known.kt2)], axis=1)
    Dc = np.stack([c1, c2, zero, zero], axis=1)
    Jt = np.swapaxes(J, 1, 2)
    return Jt @ (Dc[:, :, None] * J), Jt @ (Dk[:, :, None] * J)


def tyre_input(known: KnownConstants) -> np.ndarray:
    """B_y ``(4, 2)`` of ``F = B_y [y1, y2]`` (Eq. 2d): tyre road profile (m) to force (N)."""
    B = np.zeros((4, 2))
    B[2, 0], B[3, 1] = known.kt1, known.kt2
    return B


def response_rows(X: np.ndarray, known: KnownConstants) -> np.ndarray:
    """R ``(n, 2, 4)`` of Eq. (5): ``z1 = x - a1 theta`` (front), ``z2 = x + a2 theta`` (rear)."""
    a1 = _columns(X)[8]
    R = np.zeros((a1.size, 2, 4))
    R[:, :, 0] = 1.0
    R[:, 0, 1] = -a1
    R[:, 1, 1] = known.L - a1
    return R


def physical(X: np.ndarray, known: KnownConstants) -> np.ndarray:
    """Masses > 0, stiffness, damping >= 0, finite, 0 < a1 < L (else f = inf, no simulation)."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    ok = np.all(np.isfinite(X), axis=1)
    ok &= np.all(X[:, :4] > 0, axis=1) & np.all(X[:, 4:8] >= 0, axis=1)
    ok &= (X[:, 8] > 0) & (X[:, 8] < known.L)
    return ok
