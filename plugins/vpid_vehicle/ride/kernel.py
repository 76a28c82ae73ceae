"""The compiled recurrence of :mod:`.linear` (numba; imported on the first simulation).

Structure of arrays: every matrix is ``(rows, cols, n)`` with the candidate innermost and
contiguous, and the loop over candidates is the innermost loop, so the compiler may vectorise
across candidates. No fast-math: each candidate's arithmetic is the same whatever the batch.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def run(A, U, V, Ox, Ou, u, y):  # pragma: no cover - compiled
    s, n = A.shape[0], A.shape[2]
    r, p, N = U.shape[1], Ox.shape[0], u.shape[0]
    x = np.zeros((s, n))
    nxt = np.empty((s, n))
    acc = np.empty(n)
    for k in range(N):
        for j in range(p):
            acc[:] = 0.0
            for m in range(s):
                row = Ox[j, m]
                xm = x[m]
                for lane in range(n):
                    acc[lane] += row[lane] * xm[lane]
            for m in range(r):
                um = u[k, m]
                if um != 0.0:
                    row = Ou[j, m]
                    for lane in range(n):
                        acc[lane] += row[lane] * um
            y[j, k, :] = acc
        if k + 1 == N:
            break
        for a in range(s):
            acc[:] = 0.0
            for m in range(s):
                row = A[a, m]
                xm = x[m]
                for lane in range(n):
                    acc[lane] += row[lane] * xm[lane]
            for m in range(r):
                um, un = u[k, m], u[k + 1, m]
                if um != 0.0 or un != 0.0:
                    ru, rv = U[a, m], V[a, m]
                    for lane in range(n):
                        acc[lane] += ru[lane] * um + rv[lane] * un
            nxt[a, :] = acc
        x[:, :] = nxt



@numba.njit(cache=True)
def _mf(alpha, B, C, D, E):  # pragma: no cover - compiled
    """Magic Formula lateral force (N) at slip angle ``alpha`` (rad)."""
    x = B * alpha
    return D * np.sin(C * np.arctan(x - E * (x - np.arctan(x))))


@numba.njit(cache=True)
def _rates(vy, r, delta, P, i, m, Iz, lf, lr, vx, E):  # pragma: no cover - compiled
    af = delta - (vy + lf * r) / vx
    ar = -(vy - lr * r) / vx
    fy_f = _mf(af, P[i, 0], P[i, 1], P[i, 2], E)
    fy_r = _mf(ar, P[i, 3], P[i, 4], P[i, 5], E)
    return (fy_f + fy_r) / m - vx * r, (lf * fy_f - lr * fy_r) / Iz, (fy_f + fy_r) / m


@numba.njit(cache=True)
def mf_single_track(P, Iz, delta, dt, m, lf, lr, vx, E, y):  # pragma: no cover - compiled
    """The single-track model with a Magic Formula tyre per axle, classical RK4 at ``dt``
    with the steer linear between samples; ``P`` rows ``[Bf, Cf, Df, Br, Cr, Dr]``, ``Iz``
    per row. Writes ``y[i, k] = [r, ay, beta]``."""
    n, N = P.shape[0], delta.shape[0]
    for i in range(n):
        vy, r = 0.0, 0.0
        for k in range(N):
            _, _, ay = _rates(vy, r, delta[k], P, i, m, Iz[i], lf, lr, vx, E)
            y[i, k, 0], y[i, k, 1], y[i, k, 2] = r, ay, vy / vx
            if k + 1 == N:
                break
            d0, d1 = delta[k], delta[k + 1]
            dm = 0.5 * (d0 + d1)
            k1v, k1r, _ = _rates(vy, r, d0, P, i, m, Iz[i], lf, lr, vx, E)
            k2v, k2r, _ = _rates(vy + 0.5 * dt * k1v, r + 0.5 * dt * k1r, dm, P, i, m, Iz[i],
                                 lf, lr, vx, E)
            k3v, k3r, _ = _rates(vy + 0.5 * dt * k2v, r + 0.5 * dt * k2r, dm, P, i, m, Iz[i],
                                 lf, lr, vx, E)
            k4v, k4r, _ = _rates(vy + dt * k3v, r + dt * k3r, d1, P, i, m, Iz[i], lf, lr, vx, E)
            vy += dt / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
            r += dt / 6.0 * (k1r + 2 * k2r + 2 * k3r + k4r)
