"""The adaptive-feasible mutation in one compiled loop (numba), for speed only (the numpy
reference of :mod:`vpid_ga.mutation` costs about 5 µs per evaluation at 9 parameters, the
vehicle objective 3): the same children from the same random numbers, bit for bit (tested).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _active(x, lower, upper, tol, active, active_first):  # pragma: no cover - compiled
    """Mark the coordinates within ``tol`` of a bound, active ones first; how many are active."""
    dim = x.shape[0]
    nt = 0
    for j in range(dim):
        active[j] = abs(x[j] - lower[j]) <= tol or abs(x[j] - upper[j]) <= tol
        if active[j]:
            active_first[nt] = j
            nt += 1
    k = nt
    for j in range(dim):
        if not active[j]:
            active_first[k] = j
            k += 1
    return nt


@njit(cache=True)
def _basis(p, below_u, diagonal, order_u, L, basis):  # pragma: no cover - compiled
    """``P L P^T`` of one row's random numbers (as :func:`vpid_ga.mutation.box_directions`)."""
    dim = diagonal.shape[0]
    for a in range(dim):
        for b in range(dim):
            v = 0.0
            if a > b:
                w = (p + 1.0) * below_u[a, b] - 0.5
                v = np.sign(w) * np.floor(np.abs(w) + 0.5)
            L[a, b] = v + diagonal[a] * (1.0 if a == b else 0.0)
    perm = np.argsort(order_u)
    for a in range(dim):
        for b in range(dim):
            basis[a, b] = L[perm[a], perm[b]]


@njit(cache=True)
def _first_feasible(x, step, lower, upper, basis, slot_cols, trial, real, nt, out, mutant
                    ):  # pragma: no cover - compiled
    """``out`` = the first trial inside the box (as :func:`vpid_ga.mutation.trial_directions`)."""
    dim = x.shape[0]
    for k in range(real):
        col = slot_cols[trial[k]]
        sign = 1.0 if (k < dim or (2 * dim <= k < 2 * dim + nt)) else -1.0
        inside = True
        for j in range(dim):
            d = basis[j, col] if col < dim else (1.0 if j == col - dim else 0.0)
            mutant[j] = x[j] + step * (sign * d)
            inside = inside and lower[j] <= mutant[j] <= upper[j]
        if inside:
            out[:] = mutant
            return
    out[:] = x


@njit(cache=True)
def children(X, step, lower, upper, tol, below_u, diagonal, order_u, trial_u):  # pragma: no cover
    """One child per row of ``X``, from the reference's draws: ``below_u`` (the basis below
    its diagonal), ``diagonal`` (``±p``), ``order_u`` (the permutation), ``trial_u`` (the
    trial order)."""
    n, dim = X.shape
    p = 1.0 / np.sqrt(step)
    out = np.empty_like(X)
    L, basis = np.empty((dim, dim)), np.empty((dim, dim))
    active = np.empty(dim, np.bool_)
    active_first = np.empty(dim, np.int64)
    slot_cols = np.empty(4 * dim, np.int64)
    keys = np.empty(4 * dim)
    mutant = np.empty(dim)
    for i in range(n):
        nt = _active(X[i], lower, upper, tol, active, active_first)
        _basis(p, below_u[i], diagonal[i], order_u[i], L, basis)
        for r in range(2 * dim):  # every basis column twice, then the tangent cone twice
            slot_cols[r] = r % dim
            slot_cols[2 * dim + r] = dim + active_first[r % max(nt, 1)]
        real = 2 * (dim + nt)
        for s in range(4 * dim):  # a random order of the real slots, the padding last
            keys[s] = trial_u[i, s] if s < real else np.inf
        trial = np.argsort(keys, kind="mergesort")
        _first_feasible(X[i], step, lower, upper, basis, slot_cols, trial, real, nt, out[i],
                        mutant)
    return out
