"""The compiled loops of the ride models (numba; imported on the first simulation), the
candidate innermost and contiguous so the compiler vectorises across candidates; no fast-math
(each candidate's arithmetic is the same whatever the batch)."""

from __future__ import annotations

import math

import numba
import numpy as np

from . import vecmath
from .blocks import load_block

#: Candidates per block of :func:`run_table_loops` (as in :mod:`.codegen`).
LANES = 4
#: No GIL, cached, numpy's floating point (a singular matrix gives inf/NaN, no exception).
_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}


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


@numba.njit(inline="always", error_model="numpy")
def _mf(alpha, B, C, D, E):  # pragma: no cover - compiled
    """Magic Formula lateral force (N) at slip angle ``alpha`` (rad)."""
    x = B * alpha
    return D * vecmath.sin(C * vecmath.atan(x - E * (x - vecmath.atan(x))))


@numba.njit(inline="always", error_model="numpy")
def _rates(vy, r, delta, P, i, m, Iz, lf, lr, vx, E):  # pragma: no cover - compiled
    af = delta - (vy + lf * r) / vx
    ar = -(vy - lr * r) / vx
    fy_f = _mf(af, P[0, i], P[1, i], P[2, i], E)
    fy_r = _mf(ar, P[3, i], P[4, i], P[5, i], E)
    return (fy_f + fy_r) / m - vx * r, (lf * fy_f - lr * fy_r) / Iz, (fy_f + fy_r) / m


@numba.njit(**_OPTS)
def mf_single_track(P, Iz, delta, dt, m, lf, lr, vx, E, y):  # pragma: no cover - compiled
    """The single-track model with a Magic Formula tyre per axle by RK4 at ``dt``, the steer
    linear between samples; ``P`` rows ``[Bf, Cf, Df, Br, Cr, Dr]``; ``y[k, :, i] = [r, ay,
    beta]``."""
    n, N = P.shape[1], delta.shape[0]
    vy, r = np.zeros(n), np.zeros(n)
    kv, kr = np.empty((4, n)), np.empty((4, n))
    h = 0.5 * dt
    for k in range(N):
        d0 = delta[k]
        last = k + 1 == N
        d1 = d0 if last else delta[k + 1]
        dm = 0.5 * (d0 + d1)
        # One loop per RK4 stage, each over the candidates (a small body the compiler keeps
        # in registers, 4 candidates at a time). The sample's lateral acceleration and the
        # first stage are one evaluation of the tyres.
        for i in range(n):
            kv[0, i], kr[0, i], ay = _rates(vy[i], r[i], d0, P, i, m, Iz[i], lf, lr, vx, E)
            y[k, 0, i], y[k, 1, i], y[k, 2, i] = r[i], ay, vy[i] / vx
        if last:
            break
        for i in range(n):
            kv[1, i], kr[1, i], _ = _rates(vy[i] + h * kv[0, i], r[i] + h * kr[0, i], dm, P,
                                           i, m, Iz[i], lf, lr, vx, E)
        for i in range(n):
            kv[2, i], kr[2, i], _ = _rates(vy[i] + h * kv[1, i], r[i] + h * kr[1, i], dm, P,
                                           i, m, Iz[i], lf, lr, vx, E)
        for i in range(n):
            kv[3, i], kr[3, i], _ = _rates(vy[i] + dt * kv[2, i], r[i] + dt * kr[2, i], d1,
                                           P, i, m, Iz[i], lf, lr, vx, E)
            vy[i] += dt / 6.0 * (kv[0, i] + 2 * kv[1, i] + 2 * kv[2, i] + kv[3, i])
            r[i] += dt / 6.0 * (kr[0, i] + 2 * kr[1, i] + 2 * kr[2, i] + kr[3, i])


@numba.njit(**_OPTS)
def _inverse(S, out, work):  # pragma: no cover - compiled
    """``out`` = ``S``'s inverse by Gauss-Jordan with pivoting (singular: inf/NaN, no raise)."""
    d = S.shape[0]
    work[:, :] = S
    out[:, :] = 0.0
    for i in range(d):
        out[i, i] = 1.0
    for col in range(d):
        piv = col
        for row in range(col + 1, d):
            if abs(work[row, col]) > abs(work[piv, col]):
                piv = row
        if piv != col:
            for m in range(d):
                work[col, m], work[piv, m] = work[piv, m], work[col, m]
                out[col, m], out[piv, m] = out[piv, m], out[col, m]
        inv = 1.0 / work[col, col]
        for m in range(d):
            work[col, m] *= inv
            out[col, m] *= inv
        for row in range(d):
            if row != col:
                f = work[row, col]
                if f != 0.0:
                    for m in range(d):
                        work[row, m] -= f * work[col, m]
                        out[row, m] -= f * out[col, m]


@numba.njit(**_OPTS)
def newmark_table(M, C, K, F, Pa, Pv, Pq, Pu, dt, gamma, beta, u0, T, w0):  # pragma: no cover
    """Newmark's shifted recurrence per candidate: ``w_k = x_k - V u_k``, ``w_{k+1} = A w_k +
    (A V + U) u_k``, ``y_k = Ox w_k + (Ox V + Ou) u_k`` into ``T[c]`` (rows: ``2d`` states then
    ``p`` outputs; terms: states then inputs) and ``w0[c] = -V u_0`` (from rest). Arrays as
    :class:`.linear.LinearSystem`'s with a leading axis of ``n`` or 1."""
    n, d = T.shape[0], M.shape[1]
    r, p, s = F.shape[2], Pa.shape[1], 2 * M.shape[1]
    Minv, Sinv, work = np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    G = np.empty((d, s))  # a = G x + H u
    H = np.empty((d, r))
    Smat = np.empty((d, d))
    SKC = np.empty((d, s))  # Sinv [K C]
    SF = np.empty((d, r))  # Sinv F
    P = np.empty((s, s + r))  # predictor [P Q]: x_p = P x + Q u
    Z = np.empty((d, s + r))  # Sinv [K C] [P Q]
    V = np.empty((s, r))
    h2, c1, c2 = beta * dt * dt, (0.5 - beta) * dt * dt, (1.0 - gamma) * dt
    for c in range(n):
        cm, cc, ck, cf = c % M.shape[0], c % C.shape[0], c % K.shape[0], c % F.shape[0]
        ca, cv, cq, cu = c % Pa.shape[0], c % Pv.shape[0], c % Pq.shape[0], c % Pu.shape[0]
        _inverse(M[cm], Minv, work)
        for i in range(d):
            for j in range(d):
                Smat[i, j] = M[cm, i, j] + gamma * dt * C[cc, i, j] + h2 * K[ck, i, j]
        _inverse(Smat, Sinv, work)
        for i in range(d):
            for j in range(d):
                gk, gc, sk, sc = 0.0, 0.0, 0.0, 0.0
                for m in range(d):
                    gk += Minv[i, m] * K[ck, m, j]
                    gc += Minv[i, m] * C[cc, m, j]
                    sk += Sinv[i, m] * K[ck, m, j]
                    sc += Sinv[i, m] * C[cc, m, j]
                G[i, j], G[i, d + j] = -gk, -gc
                SKC[i, j], SKC[i, d + j] = sk, sc
            for j in range(r):
                h, sf = 0.0, 0.0
                for m in range(d):
                    h += Minv[i, m] * F[cf, m, j]
                    sf += Sinv[i, m] * F[cf, m, j]
                H[i, j], SF[i, j] = h, sf
        # predictor: [q + dt v + c1 a; v + c2 a] with a = G x + H u
        for i in range(d):
            for j in range(s):
                P[i, j] = c1 * G[i, j] + (1.0 if j == i else 0.0) + (dt if j == d + i else 0.0)
                P[d + i, j] = c2 * G[i, j] + (1.0 if j == d + i else 0.0)
            for j in range(r):
                P[i, s + j], P[d + i, s + j] = c1 * H[i, j], c2 * H[i, j]
        # corrector: x = x_p - D Sinv [K C] x_p + D Sinv F u', D = [beta dt^2 I; gamma dt I]
        for i in range(d):
            for j in range(s + r):
                t = 0.0
                for m in range(s):
                    t += SKC[i, m] * P[m, j]
                Z[i, j] = t
        for i in range(s):
            scale = h2 if i < d else gamma * dt
            for j in range(s + r):  # [A U]
                T[c, i, j] = P[i, j] - scale * Z[i % d, j]
            for j in range(r):
                V[i, j] = scale * SF[i % d, j]
        # outputs y = Pa a + Pv v + Pq q + Pu u = Ox x + Ou u
        for j in range(p):
            for m in range(s):
                t = Pq[cq, j, m] if m < d else Pv[cv, j, m - d]
                for i in range(d):
                    t += Pa[ca, j, i] * G[i, m]
                T[c, s + j, m] = t
            for i in range(r):
                t = Pu[cu, j, i]
                for m in range(d):
                    t += Pa[ca, j, m] * H[m, i]
                T[c, s + j, s + i] = t  # Ou, shifted below
        # the shift: input terms A V + U (state rows), Ox V + Ou (outputs)
        for row in range(s + p):
            for i in range(r):
                t = 0.0
                for m in range(s):
                    t += T[c, row, m] * V[m, i]
                T[c, row, s + i] += t
        for m in range(s):
            t = 0.0
            for i in range(r):
                t += V[m, i] * u0[i]
            w0[c, m] = -t


@numba.njit(**_OPTS)
def _step_loops(blk, W, s, p, st):  # pragma: no cover - compiled
    """One step of every lane as loops; the next state built in scratch slots, then copied."""
    scratch = st + (s + p) * LANES
    for lane in range(LANES):
        for row in range(s + p):
            o = row * W + lane
            t = 0.0
            for m in range(s):
                t += blk[o + m * LANES] * blk[st + m * LANES + lane]
            if row < s:
                blk[scratch + row * LANES + lane] = t
            else:
                blk[st + row * LANES + lane] = t
        for a in range(s):
            blk[st + a * LANES + lane] = blk[scratch + a * LANES + lane]


@numba.njit(**_OPTS)
def run_table_loops(T, w0, u, y):  # pragma: no cover - compiled
    """The outputs of :func:`newmark_table`'s recurrence: :mod:`.codegen`'s loops, any sizes."""
    n, R, S = T.shape
    s = w0.shape[1]
    p, r = R - s, S - s
    W = S * LANES
    st = R * W
    blk = np.zeros(st + (R + s) * LANES)  # table, state and output slots, scratch
    for j0 in range(0, n, LANES):
        load_block(T, w0, j0, blk, LANES, st)
        for k in range(u.shape[0]):
            _step_loops(blk, W, s, p, st)
            nonzero = False
            for i in range(r):
                nonzero = nonzero or u[k, i] != 0.0
            if nonzero:  # input terms after the state terms (a skipped term would add 0)
                for row in range(R):
                    for lane in range(LANES):
                        o = row * W + s * LANES + lane
                        t = blk[st + row * LANES + lane]
                        for i in range(r):
                            t += blk[o + i * LANES] * u[k, i]
                        blk[st + row * LANES + lane] = t
            for j in range(p):
                for lane in range(min(LANES, n - j0)):
                    y[j, k, j0 + lane] = blk[st + (s + j) * LANES + lane]


@numba.njit(inline="always", error_model="numpy")
def _slip_angle(lateral, vx):  # pragma: no cover - compiled
    """``atan2(lateral, |vx|)`` (rad), vectorisable (``|vx|`` floored at 1e-12 m/s)."""
    return vecmath.atan(lateral / max(abs(vx), 1e-12))


@numba.njit(error_model="numpy")
def _dynamic_rates(vx, vy, r, d, sd, cd, delta, P, i, m, lf, lr):  # pragma: no cover
    """``(vx', vy', r')`` of Bayesrace's equations; ``sd``, ``cd``: the steer's sine, cosine."""
    af = delta - _slip_angle(lf * r + vy, vx) + P[4, i]
    ar = _slip_angle(lr * r - vy, vx) + P[10, i]
    ffy = P[5, i] + _mf(af, P[0, i], P[1, i], P[2, i], P[3, i])
    fry = P[11, i] + _mf(ar, P[6, i], P[7, i], P[8, i], P[9, i])
    frx = (P[12, i] - P[13, i] * vx) * d - P[14, i] - P[15, i] * vx * vx
    return ((frx - ffy * sd) / m + vy * r, (fry + ffy * cd) / m - vx * r,
            (ffy * lf * cd - fry * lr) / P[16, i])


@numba.njit(**_OPTS)
def dynamic_single_track(P, drive, steer, dt, sub, m, lf, lr, x0, y):  # pragma: no cover
    """The dynamic single-track model (``P`` rows :data:`.bayesrace.DYNAMIC_ROWS`) driven
    by ``drive`` and ``steer`` (rad) held over each interval, by RK4 at ``dt / sub`` from
    ``x0``: ``y[k, :, i] = (vx, vy, r)`` (m/s, m/s, rad/s)."""
    n, N = P.shape[1], y.shape[0]
    vx, vy, r = np.full(n, x0[0]), np.full(n, x0[1]), np.full(n, x0[2])
    ax, ay, ar = np.empty((4, n)), np.empty((4, n)), np.empty((4, n))  # stage rates
    h = dt / sub
    for k in range(N):
        for i in range(n):
            y[k, 0, i], y[k, 1, i], y[k, 2, i] = vx[i], vy[i], r[i]
        if k + 1 == N:
            break
        d, delta = drive[k], steer[k]
        sd, cd = math.sin(delta), math.cos(delta)
        for _ in range(sub):
            for i in range(n):
                ax[0, i], ay[0, i], ar[0, i] = _dynamic_rates(vx[i], vy[i], r[i], d, sd, cd,
                                                              delta, P, i, m, lf, lr)
            for i in range(n):
                ax[1, i], ay[1, i], ar[1, i] = _dynamic_rates(
                    vx[i] + 0.5 * h * ax[0, i], vy[i] + 0.5 * h * ay[0, i],
                    r[i] + 0.5 * h * ar[0, i], d, sd, cd, delta, P, i, m, lf, lr)
            for i in range(n):
                ax[2, i], ay[2, i], ar[2, i] = _dynamic_rates(
                    vx[i] + 0.5 * h * ax[1, i], vy[i] + 0.5 * h * ay[1, i],
                    r[i] + 0.5 * h * ar[1, i], d, sd, cd, delta, P, i, m, lf, lr)
            for i in range(n):
                ax[3, i], ay[3, i], ar[3, i] = _dynamic_rates(
                    vx[i] + h * ax[2, i], vy[i] + h * ay[2, i], r[i] + h * ar[2, i], d, sd,
                    cd, delta, P, i, m, lf, lr)
                vx[i] += h / 6.0 * (ax[0, i] + 2 * ax[1, i] + 2 * ax[2, i] + ax[3, i])
                vy[i] += h / 6.0 * (ay[0, i] + 2 * ay[1, i] + 2 * ay[2, i] + ay[3, i])
                r[i] += h / 6.0 * (ar[0, i] + 2 * ar[1, i] + 2 * ar[2, i] + ar[3, i])


@numba.njit(inline="always", error_model="numpy")
def _axle_force(alpha, P, i, first, linear):  # pragma: no cover - compiled
    """An axle's lateral force (N) at slip ``alpha``: ``C alpha`` (``linear``; ``C`` in row
    ``first``) or the Magic Formula ``D sin(C atan(B alpha))`` (rows ``first .. first + 2``:
    ``B, C, D``)."""
    if linear:
        return P[first, i] * alpha
    # the Magic Formula with curvature 0, written out: one arc tangent, not two
    return P[first + 2, i] * vecmath.sin(P[first + 1, i] * vecmath.atan(P[first, i] * alpha))


@numba.njit(error_model="numpy")
def _scheduled_rates(vy, r, vx, cd, delta, P, i, linear, m, lf, lr):  # pragma: no cover
    """``(vy', r')`` at the forward speed ``vx`` (an input); ``cd``: the steer's cosine."""
    rear = 1 if linear else 3
    ffy = _axle_force(delta - _slip_angle(vy + lf * r, vx), P, i, 0, linear)
    fry = _axle_force(_slip_angle(lr * r - vy, vx), P, i, rear, linear)
    return (fry + ffy * cd) / m - vx * r, (lf * ffy * cd - lr * fry) / P[P.shape[0] - 1, i]


@numba.njit(**_OPTS)
def scheduled_single_track(P, linear, vx, delta, starts, H, sub, dt, m, lf, lr, x0,
                           y):  # pragma: no cover - compiled
    """The single-track model, ``vx`` an input, over prediction windows: ``P`` ``[Cf, Cr,
    Iz]`` (``linear``, N/rad) or ``[Bf, Cf, Df, Br, Cr, Dr, Iz]``; ``vx`` (m/s), ``delta``
    (rad) linear between samples; window ``w`` from ``x0[w] = (vy, r)`` at ``starts[w]`` for
    ``H`` samples by RK4 at ``dt / sub``: ``y[w, j, :, i] = (vy, r)``. Its helpers are called,
    not inlined by numba: inlined (the tyre model a constant in each branch) the first call
    compiled for 46 s and the linear tyres ran 11 % faster; called, 5 s (same results to the
    bit; measured side by side, numba 0.68, 64 candidates on the racecar record)."""
    n, W = P.shape[1], starts.shape[0]
    vy, r = np.empty(n), np.empty(n)
    avy, ar = np.empty((4, n)), np.empty((4, n))  # stage rates
    h = dt / sub
    for w in range(W):
        vy[:], r[:] = x0[w, 0], x0[w, 1]
        for j in range(H):
            for i in range(n):
                y[w, j, 0, i], y[w, j, 1, i] = vy[i], r[i]
            if j + 1 == H:
                break
            k = starts[w] + j
            for s in range(sub):
                # the inputs at the stage times: start, middle and end of the substep
                a0, a1, a2 = s / sub, (s + 0.5) / sub, (s + 1.0) / sub
                v0 = vx[k] + a0 * (vx[k + 1] - vx[k])
                v1 = vx[k] + a1 * (vx[k + 1] - vx[k])
                v2 = vx[k] + a2 * (vx[k + 1] - vx[k])
                d0 = delta[k] + a0 * (delta[k + 1] - delta[k])
                d1 = delta[k] + a1 * (delta[k + 1] - delta[k])
                d2 = delta[k] + a2 * (delta[k + 1] - delta[k])
                c0, c1, c2 = math.cos(d0), math.cos(d1), math.cos(d2)
                for i in range(n):
                    avy[0, i], ar[0, i] = _scheduled_rates(vy[i], r[i], v0, c0, d0, P, i,
                                                           linear, m, lf, lr)
                for i in range(n):
                    avy[1, i], ar[1, i] = _scheduled_rates(
                        vy[i] + 0.5 * h * avy[0, i], r[i] + 0.5 * h * ar[0, i], v1, c1,
                        d1, P, i, linear, m, lf, lr)
                for i in range(n):
                    avy[2, i], ar[2, i] = _scheduled_rates(
                        vy[i] + 0.5 * h * avy[1, i], r[i] + 0.5 * h * ar[1, i], v1, c1,
                        d1, P, i, linear, m, lf, lr)
                for i in range(n):
                    avy[3, i], ar[3, i] = _scheduled_rates(
                        vy[i] + h * avy[2, i], r[i] + h * ar[2, i], v2, c2, d2, P, i,
                        linear, m, lf, lr)
                    vy[i] += h / 6.0 * (avy[0, i] + 2 * avy[1, i] + 2 * avy[2, i] + avy[3, i])
                    r[i] += h / 6.0 * (ar[0, i] + 2 * ar[1, i] + 2 * ar[2, i] + ar[3, i])
