"""The fast path: Newmark-beta for the 4-DOF half-car as a structure-of-arrays kernel (numba),
``s_{k+1} = A s_k + W y_k`` per candidate (``y`` the two tyre inputs, m) with z1'', z2'' two
more rows, the candidates in blocks of ``LANES`` (the innermost, contiguous axis), Eq. (3)
accumulated on the fly; no fast-math, so bit-identical for any batch and thread count
(tested). How and why: docs/vehicle.md, "Speed". Imported on the first evaluation; cached.
"""

from __future__ import annotations

import functools
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit

#: Candidates per block (SIMD lanes): the innermost, contiguous axis of every block array.
LANES = 4
#: Rows of the coefficient table: 8 state rows, then the z1'' and z2'' read-outs.
N_ROWS = 10
#: Terms per row: 8 state coefficients, then the two input coefficients.
N_TERMS = 10
_ROW = N_TERMS * LANES  # floats between two rows of the table in a block
_STATE = N_ROWS * _ROW  # offset of the state (8 slots), then the read-outs (2 slots)
#: Floats per block: table, state, read-outs, at compile-time offsets (nothing aliases).
BLOCK = _STATE + 10 * LANES
_Z1 = _STATE + 8 * LANES  # read-out slots
_Z2 = _STATE + 9 * LANES
#: Smallest number of candidates per thread worth a thread hand-off (measured with
#: ``benchmarks/bench_vehicle.py --threshold``; see docs/vehicle.md).
MIN_PER_THREAD = 48

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}


@njit(**_OPTS)
def _inverse_spd4(S: np.ndarray, work: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    """Inverse of a 4x4 SPD matrix by Gauss-Jordan without pivoting (a non-positive pivot
    gives inf/NaN: f = inf); ``work`` is 4x4 scratch."""
    for i in range(4):
        for j in range(4):
            work[i, j] = S[i, j]
            out[i, j] = 1.0 if i == j else 0.0
    for i in range(4):
        p = 1.0 / work[i, i]
        for j in range(4):
            work[i, j] *= p
            out[i, j] *= p
        for r in range(4):
            if r != i:
                f = work[r, i]
                if f != 0.0:
                    for j in range(4):
                        work[r, j] -= f * work[i, j]
                        out[r, j] -= f * out[i, j]


@njit(**_OPTS)
def _physical(x: np.ndarray, L: float) -> bool:  # pragma: no cover - compiled
    """The rule of :func:`vpid_vehicle.model.physical`, compiled."""
    ok = x[8] > 0.0 and x[8] < L
    for i in range(9):
        if not np.isfinite(x[i]) or (i < 4 and x[i] <= 0.0) or x[i] < 0.0:
            ok = False
    return ok


@njit(**_OPTS)
def _coefficients(
    x: np.ndarray, L: float, kt1: float, kt2: float, dt: float, gamma: float, beta: float,
    y10: float, y20: float, blk: np.ndarray, lane: int, ws: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Write lane ``lane`` of a block for the candidate ``x``: the table entry (row r, term t)
    at ``blk[r * _ROW + t * LANES + lane]`` and the start state ``-V y_0`` (slot r at
    ``blk[_STATE + r * LANES + lane]``); ``ws``: scratch reused for every candidate.
    Derivation: ``a = G x + M^-1 F`` with ``G = -M^-1 [K, C]``; predictor
    ``x* = Q x + H M^-1 F_k`` with ``Q = P + H G``, ``P = [[I, dt I], [0, I]]``,
    ``H = [ca I; cv I]``; solve ``a' = Si (F' - [K, C] x*)``; corrector ``x' = x* + E a'``
    with ``E = [bd I; gd I]``. So ``A = Q - E T Q`` with ``T = Si [K, C]``,
    ``U = (I - E T) H M^-1 B`` and ``V = E Si B`` (``B``: tyre stiffnesses on the wheel rows).
    """
    ca = dt * dt * (0.5 - beta)
    cv = dt * (1.0 - gamma)
    bd = beta * dt * dt
    gd = gamma * dt
    m, I, m1, m2 = x[0], x[1], x[2], x[3]
    k1, k2, c1, c2, a1 = x[4], x[5], x[6], x[7], x[8]
    a2 = L - a1
    KC = ws[0, :4, :]  # [K, C], 4x8
    S = ws[1, :4, :4]
    Si = ws[1, 4:, :4]
    G = ws[2, :4, :]  # 4x8
    T = ws[2, 4:, :]  # 4x8
    Q = ws[3]  # 8x8
    A = ws[4]  # 8x8
    TQ = ws[5, :4, :]  # 4x8
    UV = ws[5, 4:, :]  # rows: U[:,0], U[:,1], V[:,0], V[:,1] (each 8)
    work = ws[6, :4, :4]
    TH = ws[6, 4:, :4]  # T H, 4x4
    # K (columns 0..3) and C (columns 4..7), Eq. (2b, 2c) with the K[3,1] erratum fixed.
    for i in range(4):
        for c in range(8):
            KC[i, c] = 0.0
    for off, s1, s2, t1, t2 in ((0, k1, k2, kt1, kt2), (4, c1, c2, 0.0, 0.0)):
        KC[0, off + 0] = s1 + s2
        KC[0, off + 1] = a2 * s2 - a1 * s1
        KC[0, off + 2] = -s1
        KC[0, off + 3] = -s2
        KC[1, off + 1] = s1 * a1 * a1 + s2 * a2 * a2
        KC[1, off + 2] = a1 * s1
        KC[1, off + 3] = -a2 * s2
        KC[2, off + 2] = s1 + t1
        KC[3, off + 3] = s2 + t2
        for r in range(4):
            for c in range(r):
                KC[r, off + c] = KC[c, off + r]
    mass = (m, I, m1, m2)
    for r in range(4):
        for c in range(4):
            S[r, c] = gd * KC[r, 4 + c] + bd * KC[r, c]
        S[r, r] += mass[r]
    _inverse_spd4(S, work, Si)
    for r in range(4):
        inv_m = 1.0 / mass[r]
        for c in range(8):
            G[r, c] = -KC[r, c] * inv_m
            t = 0.0
            for q in range(4):
                t += Si[r, q] * KC[q, c]
            T[r, c] = t
    for r in range(8):
        for c in range(8):
            Q[r, c] = 0.0
    for i in range(4):
        Q[i, i] = 1.0
        Q[i, 4 + i] = dt
        Q[4 + i, 4 + i] = 1.0
        for c in range(8):
            Q[i, c] += ca * G[i, c]
            Q[4 + i, c] += cv * G[i, c]
    # T Q = T P + (T H) G: the structure of P and H halves the work of a plain 4x8x8 product.
    for r in range(4):
        for i in range(4):
            TH[r, i] = ca * T[r, i] + cv * T[r, 4 + i]
    for r in range(4):
        for c in range(8):
            t = T[r, c] + (dt * T[r, c - 4] if c >= 4 else 0.0)
            for i in range(4):
                t += TH[r, i] * G[i, c]
            TQ[r, c] = t
    for i in range(4):
        for c in range(8):
            A[i, c] = Q[i, c] - bd * TQ[i, c]
            A[4 + i, c] = Q[4 + i, c] - gd * TQ[i, c]
    # Input columns: y1 acts on wheel row 2 through kt1, y2 on row 3 through kt2.
    for col in range(2):
        w = 2 + col
        kt = kt1 if col == 0 else kt2
        hd = ca * kt / mass[w]  # H M^-1 B, displacement part (row w)
        hv = cv * kt / mass[w]  # velocity part (row 4 + w)
        for i in range(4):
            th = T[i, w] * hd + T[i, 4 + w] * hv
            ui = (hd if i == w else 0.0) - bd * th
            vi = (hv if i == w else 0.0) - gd * th
            UV[col, i] = ui
            UV[col, 4 + i] = vi
            UV[2 + col, i] = bd * Si[i, w] * kt
            UV[2 + col, 4 + i] = gd * Si[i, w] * kt
    # Table rows 0..7: s_{k+1} = A s_k + W y_k with W = A V + U.
    for r in range(8):
        for c in range(8):
            blk[r * _ROW + c * LANES + lane] = A[r, c]
        for col in range(2):
            t = 0.0
            for c in range(8):
                t += A[r, c] * UV[2 + col, c]
            blk[r * _ROW + (8 + col) * LANES + lane] = t + UV[col, r]
        blk[_STATE + r * LANES + lane] = -(UV[2, r] * y10 + UV[3, r] * y20)
    # Rows 8, 9: z1'' = G[0] - a1 G[1], z2'' = G[0] + a2 G[1]; their input terms are R V.
    for out, lever in ((8, -a1), (9, a2)):
        o = out * _ROW + lane
        for c in range(8):
            blk[o + c * LANES] = G[0, c] + lever * G[1, c]
        for col in range(2):
            t = 0.0
            for c in range(8):
                t += blk[o + c * LANES] * UV[2 + col, c]
            blk[o + (8 + col) * LANES] = t


@njit(**_OPTS)
def _row(c: np.ndarray, o: int, s0: float, s1: float, s2: float, s3: float, s4: float,
         s5: float, s6: float, s7: float) -> float:  # pragma: no cover - compiled
    """The 8 state terms of a table row applied to one lane (terms ``LANES`` apart)."""
    return (((c[o] * s0 + c[o + LANES] * s1) + (c[o + 2 * LANES] * s2 + c[o + 3 * LANES] * s3))
            + ((c[o + 4 * LANES] * s4 + c[o + 5 * LANES] * s5)
               + (c[o + 6 * LANES] * s6 + c[o + 7 * LANES] * s7)))


@njit(**_OPTS)
def _prepare_block(
    X: np.ndarray, j0: int, L: float, kt1: float, kt2: float, dt: float, gamma: float,
    beta: float, y10: float, y20: float, blk: np.ndarray, ok: np.ndarray, ws: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Fill ``blk`` with rows ``j0 ...`` of ``X``; missing and non-physical lanes stay zero."""
    blk[:] = 0.0
    for lane in range(LANES):
        j = j0 + lane
        ok[lane] = j < X.shape[0] and _physical(X[j], L)
        if ok[lane]:
            _coefficients(X[j], L, kt1, kt2, dt, gamma, beta, y10, y20, blk, lane, ws)


@njit(**_OPTS)
def _step_block(blk: np.ndarray, u1: float, u2: float) -> None:  # pragma: no cover - compiled
    """One step of every lane: read-outs now, then ``s <- A s + W y`` (zero inputs skipped)."""
    for lane in range(LANES):
        s = _STATE + lane
        s0, s1, s2, s3 = blk[s], blk[s + LANES], blk[s + 2 * LANES], blk[s + 3 * LANES]
        s4, s5 = blk[s + 4 * LANES], blk[s + 5 * LANES]
        s6, s7 = blk[s + 6 * LANES], blk[s + 7 * LANES]
        z1 = _row(blk, _ROW * 8 + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        z2 = _row(blk, _ROW * 9 + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        n0 = _row(blk, lane, s0, s1, s2, s3, s4, s5, s6, s7)
        n1 = _row(blk, _ROW + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        n2 = _row(blk, _ROW * 2 + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        n3 = _row(blk, _ROW * 3 + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        n4 = _row(blk, _ROW * 4 + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        n5 = _row(blk, _ROW * 5 + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        n6 = _row(blk, _ROW * 6 + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        n7 = _row(blk, _ROW * 7 + lane, s0, s1, s2, s3, s4, s5, s6, s7)
        blk[s], blk[s + LANES], blk[s + 2 * LANES], blk[s + 3 * LANES] = n0, n1, n2, n3
        blk[s + 4 * LANES], blk[s + 5 * LANES] = n4, n5
        blk[s + 6 * LANES], blk[s + 7 * LANES] = n6, n7
        blk[s + 8 * LANES], blk[s + 9 * LANES] = z1, z2
    if u1 != 0.0 or u2 != 0.0:
        for r in range(10):
            for lane in range(LANES):
                o = r * _ROW + 8 * LANES + lane  # input terms of table row r (slot r)
                i = _STATE + r * LANES + lane
                blk[i] = blk[i] + blk[o] * u1 + blk[o + LANES] * u2


@njit(**_OPTS)
def objective(
    X: np.ndarray, L: float, kt1: float, kt2: float, y1: np.ndarray, y2: np.ndarray,
    dt: float, gamma: float, beta: float, ref: np.ndarray, f: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """``f[j]`` = Eq. (3) of row ``j`` against ``ref`` (2, N); inf if non-physical or not finite."""
    n = X.shape[0]
    N = y1.shape[0]
    den = np.sqrt(np.sum(ref[0] ** 2)) + np.sqrt(np.sum(ref[1] ** 2))
    blk = np.empty(BLOCK)
    ok = np.empty(LANES, dtype=np.bool_)
    ws = np.empty((7, 8, 8))
    err = np.empty((2, LANES))
    for j0 in range(0, n, LANES):
        _prepare_block(X, j0, L, kt1, kt2, dt, gamma, beta, y1[0], y2[0], blk, ok, ws)
        err[:] = 0.0
        for k in range(N):
            _step_block(blk, y1[k], y2[k])
            r1 = ref[0, k]
            r2 = ref[1, k]
            for lane in range(LANES):
                e1 = r1 - blk[_Z1 + lane]
                e2 = r2 - blk[_Z2 + lane]
                err[0, lane] += e1 * e1
                err[1, lane] += e2 * e2
        for lane in range(min(LANES, n - j0)):
            fj = (np.sqrt(err[0, lane]) + np.sqrt(err[1, lane])) / den
            f[j0 + lane] = fj if (ok[lane] and np.isfinite(fj)) else np.inf


@njit(**_OPTS)
def objective_rows(
    X: np.ndarray, index: np.ndarray, L: float, kt1: float, kt2: float, y1: np.ndarray,
    y2: np.ndarray, dt: float, gamma: float, beta: float, refs: np.ndarray, f: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """:func:`objective` of row ``j`` against ``refs[index[j]]`` (runs in lockstep), each value
    bit-identical to the row's against its reference alone (tested)."""
    n = X.shape[0]
    N = y1.shape[0]
    dens = np.empty(refs.shape[0])
    for m in range(refs.shape[0]):
        dens[m] = np.sqrt(np.sum(refs[m, 0] ** 2)) + np.sqrt(np.sum(refs[m, 1] ** 2))
    blk = np.empty(BLOCK)
    ok = np.empty(LANES, dtype=np.bool_)
    ws = np.empty((7, 8, 8))
    err = np.empty((2, LANES))
    lane_ref = np.zeros(LANES, dtype=np.int64)
    for j0 in range(0, n, LANES):
        _prepare_block(X, j0, L, kt1, kt2, dt, gamma, beta, y1[0], y2[0], blk, ok, ws)
        for lane in range(LANES):
            lane_ref[lane] = index[j0 + lane] if j0 + lane < n else 0
        err[:] = 0.0
        for k in range(N):
            _step_block(blk, y1[k], y2[k])
            for lane in range(LANES):
                e1 = refs[lane_ref[lane], 0, k] - blk[_Z1 + lane]
                e2 = refs[lane_ref[lane], 1, k] - blk[_Z2 + lane]
                err[0, lane] += e1 * e1
                err[1, lane] += e2 * e2
        for lane in range(min(LANES, n - j0)):
            fj = (np.sqrt(err[0, lane]) + np.sqrt(err[1, lane])) / dens[lane_ref[lane]]
            f[j0 + lane] = fj if (ok[lane] and np.isfinite(fj)) else np.inf


@njit(**_OPTS)
def simulate(
    X: np.ndarray, L: float, kt1: float, kt2: float, y1: np.ndarray, y2: np.ndarray,
    dt: float, gamma: float, beta: float, out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """``out[j]`` = z1'', z2'' (m/s^2) of row ``j``, ``(n, 2, N)``; NaN for non-physical rows."""
    n = X.shape[0]
    N = y1.shape[0]
    blk = np.empty(BLOCK)
    ok = np.empty(LANES, dtype=np.bool_)
    ws = np.empty((7, 8, 8))
    for j0 in range(0, n, LANES):
        _prepare_block(X, j0, L, kt1, kt2, dt, gamma, beta, y1[0], y2[0], blk, ok, ws)
        for k in range(N):
            _step_block(blk, y1[k], y2[k])
            for lane in range(min(LANES, n - j0)):
                out[j0 + lane, 0, k] = blk[_Z1 + lane] if ok[lane] else np.nan
                out[j0 + lane, 1, k] = blk[_Z2 + lane] if ok[lane] else np.nan


def available_threads() -> int:
    """Cores this process may run on (its CPU affinity where the OS reports it; benchmarks)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


def chunks(n: int, threads: int) -> list[tuple[int, int]]:
    """At most ``threads`` ranges of ``n`` candidates, each of ``MIN_PER_THREAD`` or more."""
    parts = max(1, min(int(threads), n // MIN_PER_THREAD))
    edges = [n * i // parts for i in range(parts + 1)]
    return [(edges[i], edges[i + 1]) for i in range(parts)]


def _run_chunked(fn, X: np.ndarray, args: tuple, out: np.ndarray, threads: int,
                 rows: tuple = ()) -> None:
    """``fn`` over the chunks of ``X`` and ``rows``, in parallel when there are several."""
    if threads <= 1 or X.shape[0] < 2 * MIN_PER_THREAD:
        fn(X, *rows, *args, out)
        return
    parts = chunks(X.shape[0], threads)
    pool = _pool(len(parts) - 1)  # the caller's thread takes the first chunk
    futures = [pool.submit(fn, X[a:b], *(r[a:b] for r in rows), *args, out[a:b])
               for a, b in parts[1:]]
    a, b = parts[0]
    fn(X[a:b], *(r[a:b] for r in rows), *args, out[a:b])
    for fut in futures:
        fut.result()


@functools.cache
def _pool(workers: int) -> ThreadPoolExecutor:
    """A pool of ``workers`` threads, made on first use and kept."""
    return ThreadPoolExecutor(max_workers=workers, thread_name_prefix="vpid-kernel")


def as_kernel_array(A: np.ndarray) -> np.ndarray:
    """``A`` as a writable C-contiguous float64 array: one numba signature, no recompilation."""
    A = np.asarray(A)
    if A.dtype == np.float64 and A.flags.c_contiguous and A.flags.writeable:
        return A
    return np.array(A, dtype=np.float64, order="C")


class Setup:
    """What a model's simulations share: known constants, Newmark settings, the tyre inputs."""

    def __init__(self, L: float, kt1: float, kt2: float, y: np.ndarray, dt: float,
                 gamma: float, beta: float) -> None:
        y = np.asarray(y, dtype=np.float64)
        self.y1 = np.array(y[:, 0], dtype=np.float64)
        self.y2 = np.array(y[:, 1], dtype=np.float64)
        self.consts = (float(L), float(kt1), float(kt2))
        self.newmark = (float(dt), float(gamma), float(beta))
        self._ref: tuple[np.ndarray | None, np.ndarray | None] = (None, None)

    def _reference(self, ref: np.ndarray) -> np.ndarray:
        """``ref`` as the kernel takes it; a read-only one (the problem's) copied once."""
        if ref is self._ref[0]:
            return self._ref[1]
        out = as_kernel_array(ref)
        if isinstance(ref, np.ndarray) and not ref.flags.writeable and ref.base is None:
            self._ref = (ref, out)
        return out

    @property
    def samples(self) -> int:
        return int(self.y1.shape[0])

    def objective(self, X: np.ndarray, ref: np.ndarray, threads: int = 1) -> np.ndarray:
        """Eq. (3) of every row of ``X`` (n, 9) against ``ref`` (2, N) on up to ``threads``."""
        X = as_kernel_array(np.atleast_2d(X))
        f = np.empty(X.shape[0])
        args = (*self.consts, self.y1, self.y2, *self.newmark, self._reference(ref))
        _run_chunked(objective, X, args, f, threads)
        return f

    def objective_rows(self, X: np.ndarray, refs: np.ndarray, index: np.ndarray,
                       threads: int = 1) -> np.ndarray:
        """Eq. (3) of row ``j`` against ``refs[index[j]]``, bit-identical to :meth:`objective`'s."""
        X = as_kernel_array(np.atleast_2d(X))
        refs = as_kernel_array(refs)
        index = np.ascontiguousarray(index, dtype=np.int64)
        if refs.ndim != 3 or refs.shape[1:] != (2, self.samples):
            raise ValueError(f"references of shape {refs.shape}, expected (m, 2, {self.samples})")
        if index.shape != (X.shape[0],) or (index.size and not (
                0 <= index.min() and index.max() < refs.shape[0])):
            raise ValueError(f"index must hold {X.shape[0]} integers in [0, {refs.shape[0]})")
        f = np.empty(X.shape[0])
        args = (*self.consts, self.y1, self.y2, *self.newmark, refs)
        _run_chunked(objective_rows, X, args, f, threads, rows=(index,))
        return f

    def responses(self, X: np.ndarray, threads: int = 1) -> np.ndarray:
        """z1'' and z2'' (m/s^2) ``(n, 2, N)``; NaN rows for non-physical candidates."""
        X = as_kernel_array(np.atleast_2d(X))
        out = np.empty((X.shape[0], 2, self.samples))
        _run_chunked(simulate, X, (*self.consts, self.y1, self.y2, *self.newmark), out, threads)
        return out
