"""Plain Newmark-beta in numpy, batched over candidates, any DOFs, ``gamma``, ``beta``: the
correctness reference the compiled kernel must meet to 1e-10 (simple on purpose, never on
the hot path). One step, with S = M + gamma dt C + beta dt^2 K:
predict ``d* = d + dt v + dt^2 (1/2 - beta) a`` and ``v* = v + dt (1 - gamma) a``, solve
``S a' = F' - C v* - K d*``, correct ``d' = d* + beta dt^2 a'``, ``v' = v* + gamma dt a'``.
The start is ``a_0 = M^-1 (F_0 - C v_0 - K d_0)``.
"""

from __future__ import annotations

import numpy as np

from .model import KnownConstants, matrices, response_rows, tyre_input


def newmark(
    M: np.ndarray,
    C: np.ndarray,
    K: np.ndarray,
    F: np.ndarray,
    dt: float,
    gamma: float = 0.5,
    beta: float = 0.25,
    d0: np.ndarray | None = None,
    v0: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate ``M a + C v + K d = F`` (``M``, ``C``, ``K`` ``(n, p, p)``; ``F`` ``(N, p)``
    or ``(N, n, p)``) on ``t_k = k dt`` from ``d0``, ``v0`` (default 0): displacement,
    velocity and acceleration, each ``(N, n, p)``."""
    M, C, K = (np.asarray(A, dtype=float) for A in (M, C, K))
    n, p = M.shape[0], M.shape[1]
    F = np.asarray(F, dtype=float)
    if F.ndim == 2:
        F = np.broadcast_to(F[:, None, :], (F.shape[0], n, p))
    N = F.shape[0]
    d = np.zeros((n, p)) if d0 is None else np.array(d0, dtype=float)
    v = np.zeros((n, p)) if v0 is None else np.array(v0, dtype=float)

    def mv(A: np.ndarray, x: np.ndarray) -> np.ndarray:
        return np.einsum("nij,nj->ni", A, x)

    a = np.linalg.solve(M, (F[0] - mv(C, v) - mv(K, d))[..., None])[..., 0]
    S_inv = np.linalg.inv(M + gamma * dt * C + beta * dt * dt * K)
    out_d, out_v, out_a = (np.empty((N, n, p)) for _ in range(3))
    out_d[0], out_v[0], out_a[0] = d, v, a
    for k in range(1, N):
        d_pred = d + dt * v + dt * dt * (0.5 - beta) * a
        v_pred = v + dt * (1.0 - gamma) * a
        a = mv(S_inv, F[k] - mv(C, v_pred) - mv(K, d_pred))
        d = d_pred + beta * dt * dt * a
        v = v_pred + gamma * dt * a
        out_d[k], out_v[k], out_a[k] = d, v, a
    return out_d, out_v, out_a


def body_accelerations(
    X: np.ndarray, known: KnownConstants, y: np.ndarray, dt: float, gamma: float, beta: float
) -> np.ndarray:
    """z1'', z2'' (m/s^2) ``(n, 2, N)`` by the plain Newmark of the tyre inputs ``y`` (m)."""
    M, C, K = matrices(X, known)
    F = y @ tyre_input(known).T
    _, _, a = newmark(M, C, K, F, dt, gamma, beta)
    R = response_rows(X, known)
    return np.einsum("nij,knj->nik", R, a)
