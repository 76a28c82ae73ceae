"""One DE generation in one compiled loop (numba), for speed only (at ps = 20 the numpy path's
30 calls cost a fifth of the vehicle objective): the same trials as :mod:`vpid_de.kernels`
from the same uniforms, bit for bit (tested). Imported lazily.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: mutation name -> id used inside the compiled loop (keys of kernels.MUTATIONS)
MUTATION_IDS = {"rand1": 0, "best2": 1, "best1": 2, "current_to_best1": 3, "rand2": 4,
                "current_to_rand1": 5}
#: bounds rule name -> id (keys of kernels.BOUNDS_RULES)
BOUNDS_IDS = {"reinit": 0, "clip": 1, "reflect": 2, "midpoint": 3}


@njit(cache=True)
def repaired(v, x, lo, hi, u, bounds_rule):  # pragma: no cover - compiled
    """A mutant coordinate ``v`` put inside ``[lo, hi]`` as the numpy bounds rules do."""
    if not (v < lo or v > hi):  # inside (a NaN passes through, as before)
        return v
    if bounds_rule == 0:
        return min(lo + u * (hi - lo), hi)
    if bounds_rule == 1:
        return min(max(v, lo), hi)
    if bounds_rule == 2:
        width = hi - lo
        y = (v - lo) % (2.0 * width)
        if y > width:
            y = 2.0 * width - y
        return min(max(lo + y, lo), hi)
    return min(max(0.5 * (x + lo) if v < lo else 0.5 * (x + hi), lo), hi)


@njit(cache=True)
def generation(X, fitness, u, n_random, mutation, F, K, CR, bounds_rule, lower, upper):
    """One generation's trials ``(ps, dim)`` from the uniforms ``u`` of ``next_generation()``."""
    ps, dim = X.shape
    best = np.argmin(fitness)
    out = np.empty_like(X)
    r = np.empty(5, np.int64)
    keys = np.empty(ps - 1)
    c = ps - 1
    for i in range(ps):
        # the n smallest keys in increasing order (ties: first index), as a stable argsort
        for j in range(ps - 1):
            keys[j] = u[i, j]
        for m in range(n_random):
            k = 0
            for j in range(1, ps - 1):
                if keys[j] < keys[k]:
                    k = j
            keys[k] = np.inf
            r[m] = k + 1 if k >= i else k
        jr = min(int(u[i, c + dim] * dim), dim - 1)
        f = F[i]
        for j in range(dim):
            x = X[i, j]
            if not (u[i, c + j] <= CR or j == jr):
                out[i, j] = x
                continue
            if mutation == 0:
                v = X[r[0], j] + f * (X[r[1], j] - X[r[2], j])
            elif mutation == 1:
                v = X[best, j] + f * (X[r[0], j] + X[r[1], j] - X[r[2], j] - X[r[3], j])
            elif mutation == 2:
                v = X[best, j] + f * (X[r[0], j] - X[r[1], j])
            elif mutation == 3:
                v = x + f * (X[best, j] - x) + f * (X[r[0], j] - X[r[1], j])
            elif mutation == 4:
                v = (X[r[0], j] + f * (X[r[1], j] - X[r[2], j])
                     + f * (X[r[3], j] - X[r[4], j]))
            else:
                v = x + K * (X[r[0], j] - x) + f * (X[r[1], j] - X[r[2], j])
            v = repaired(v, x, lower[j], upper[j], u[i, c + dim + 1 + j], bounds_rule)
            out[i, j] = v
    return out


@njit(cache=True)
def pbest_trials(X, pbest, r1, XA, r2, F, CR, u, bounds_rule, lower, upper, u_reinit
                 ):  # pragma: no cover - compiled
    """The adaptive DEs' trials from their draws: current-to-pbest/1, Eq. 8, bounds rule."""
    ps, dim = X.shape
    out = np.empty_like(X)
    for i in range(ps):
        jr = min(int(u[i, dim] * dim), dim - 1)
        f = F[i]
        for j in range(dim):
            x = X[i, j]
            if not (u[i, j] <= CR[i] or j == jr):
                out[i, j] = x
                continue
            v = x + f * (X[pbest[i], j] - x) + f * (X[r1[i], j] - XA[r2[i], j])
            ur = u_reinit[i, j] if bounds_rule == 0 else 0.0
            v = repaired(v, x, lower[j], upper[j], ur, bounds_rule)
            out[i, j] = v
    return out
