"""The pieces of differential evolution, vectorised over the population ``X`` ``(ps, dim)``
(physical units), pure and each tested alone: index draws, one mutation kernel per equation
of Gökdağ (2014) and current-to-pbest/1, Eq. 8 crossover, the bounds rules, one-to-one
selection. :mod:`vpid_de.fused` mirrors DE1-DE8's use of them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np

#: the choices of the ``bounds`` key (the keys of :data:`BOUNDS_RULES`, in the same order)
BoundsRule = Literal["reinit", "clip", "reflect", "midpoint"]

# Index drawing


def indices_from_keys(keys: np.ndarray, n: int) -> np.ndarray:
    """``(ps, n)`` indices from uniform ``keys`` ``(ps, ps - 1)``: row ``i`` holds ``n``
    distinct indices in ``0..ps-1``, none equal to ``i`` (the first ``n`` of the permutation
    that sorts the row's keys, those ``>= i`` shifted by one)."""
    ps = keys.shape[0]
    if n > ps - 1:
        raise ValueError(f"cannot draw {n} distinct indices besides i from a population of {ps}")
    r = np.argsort(keys, axis=1, kind="stable")[:, :n]
    r += r >= np.arange(ps)[:, None]
    return r


def draw_indices(rng: np.random.Generator, ps: int, n: int) -> np.ndarray:
    """:func:`indices_from_keys` with keys drawn from ``rng``."""
    return indices_from_keys(rng.random((ps, ps - 1)), n)


# Mutation kernels, kernel(X, best, r, F, K) -> V (ps, dim): ``best`` the best member's index,
# ``r`` (ps, n) from draw_indices, F a scalar or (ps, 1), K Eq. 13's combination factor.


def rand1(X: np.ndarray, best: int, r: np.ndarray, F, K=None) -> np.ndarray:
    """Eq. 7 (also Eq. 14 with F = R): ``v_i = x_r1 + F (x_r2 - x_r3)``."""
    return X[r[:, 0]] + F * (X[r[:, 1]] - X[r[:, 2]])


def best2(X: np.ndarray, best: int, r: np.ndarray, F, K=None) -> np.ndarray:
    """Eq. 9: ``v_i = x_best + F (x_r1 + x_r2 - x_r3 - x_r4)``."""
    return X[best] + F * (X[r[:, 0]] + X[r[:, 1]] - X[r[:, 2]] - X[r[:, 3]])


def best1(X: np.ndarray, best: int, r: np.ndarray, F, K=None) -> np.ndarray:
    """Eq. 10: ``v_i = x_best + F (x_r1 - x_r2)``."""
    return X[best] + F * (X[r[:, 0]] - X[r[:, 1]])


def current_to_best1(X: np.ndarray, best: int, r: np.ndarray, F, K=None) -> np.ndarray:
    """Eq. 11: ``v_i = x_i + F (x_best - x_i) + F (x_r1 - x_r2)``."""
    return X + F * (X[best] - X) + F * (X[r[:, 0]] - X[r[:, 1]])


def rand2(X: np.ndarray, best: int, r: np.ndarray, F, K=None) -> np.ndarray:
    """Eq. 12: ``v_i = x_r1 + F (x_r2 - x_r3) + F (x_r4 - x_r5)``."""
    return X[r[:, 0]] + F * (X[r[:, 1]] - X[r[:, 2]]) + F * (X[r[:, 3]] - X[r[:, 4]])


def current_to_rand1(X: np.ndarray, best: int, r: np.ndarray, F, K) -> np.ndarray:
    """Eq. 13 (Karaboğa and Ökdem): ``v_i = x_i + K (x_r1 - x_i) + F (x_r2 - x_r3)``."""
    return X + K * (X[r[:, 0]] - X) + F * (X[r[:, 1]] - X[r[:, 2]])


#: name -> (kernel, number of random indices besides i it needs)
MUTATIONS: dict[str, tuple[Callable[..., np.ndarray], int]] = {
    "rand1": (rand1, 3),
    "best2": (best2, 4),
    "best1": (best1, 2),
    "current_to_best1": (current_to_best1, 2),
    "rand2": (rand2, 5),
    "current_to_rand1": (current_to_rand1, 3),
}


# current-to-pbest/1 with an external archive (Zhang and Sanderson 2009; SHADE, L-SHADE)


def pbest_indices(rng: np.random.Generator, f: np.ndarray, count: np.ndarray | int) -> np.ndarray:
    """For every target, one of the ``count`` best, uniform (itself too, as JADE; ties: lower
    index first); ``count``: an integer or one per target (SHADE)."""
    order = np.argsort(f, kind="stable")
    count = np.asarray(count, dtype=np.intp)
    return order[np.minimum((rng.random(f.shape[0]) * count).astype(np.intp), count - 1)]


def partner_indices(rng: np.random.Generator, r1: np.ndarray, n_total: int) -> np.ndarray:
    """``r2`` of current-to-pbest/1: for every target ``i``, an index uniform over
    ``0..n_total-1`` (the population, then the archive) except ``i`` and ``r1[i]`` (one of
    ``n_total - 2`` values shifted past the two, in increasing order)."""
    ps = r1.shape[0]
    if n_total < 3:
        raise ValueError(f"cannot draw r2 besides i and r1 from {n_total} vectors")
    lo = np.minimum(np.arange(ps), r1)
    hi = np.maximum(np.arange(ps), r1)
    k = np.minimum((rng.random(ps) * (n_total - 2)).astype(np.intp), n_total - 3)
    k += k >= lo
    k += k >= hi
    return k


def current_to_pbest1(
    X: np.ndarray, pbest: np.ndarray, r1: np.ndarray, XA: np.ndarray, r2: np.ndarray, F
) -> np.ndarray:
    """``v_i = x_i + F_i (x_pbest - x_i) + F_i (x_r1 - x~_r2)`` (JADE's Eq. 4 with archive);
    ``r2`` indexes ``XA``, the population stacked over the archive; ``F``: scalar or ``(ps, 1)``."""
    return X + F * (X[pbest] - X) + F * (X[r1] - XA[r2])


# Crossover and selection


def crossover_from_uniforms(
    X: np.ndarray, V: np.ndarray, CR: float | np.ndarray, u: np.ndarray, u_j: np.ndarray
) -> np.ndarray:
    """Eq. 8: gene ``j`` of trial ``i`` is the mutant's when ``rand_j <= CR`` (``u``, (ps,
    dim)) or ``j == rnbr(i) = floor(u_j dim)``, else the parent's; ``CR``: scalar or (ps, 1)."""
    ps, dim = X.shape
    take = u <= CR
    take[np.arange(ps), np.minimum((u_j * dim).astype(np.intp), dim - 1)] = True
    return np.where(take, V, X)


def binomial_crossover(
    X: np.ndarray, V: np.ndarray, CR: float | np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """:func:`crossover_from_uniforms` drawn from ``rng`` (at least one mutant gene per trial)."""
    ps, dim = X.shape
    u = rng.random((ps, dim + 1))
    return crossover_from_uniforms(X, V, CR, u[:, :dim], u[:, dim])


def greedy_selection(
    X: np.ndarray, fX: np.ndarray, U: np.ndarray, fU: np.ndarray, ties: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Trial ``u_i`` replaces ``x_i`` when ``f(u_i) < f(x_i)`` (Gökdağ: "if u yields a
    smaller OF value"; JADE), or ``<=`` with ``ties`` (SHADE, L-SHADE: drift across plateaus).
    A failed trial (inf) never replaces a finite member. New arrays; the inputs stay."""
    better = fU <= fX if ties else fU < fX
    return np.where(better[:, None], U, X), np.where(better, fU, fX)


# Bounds rules, rule(U, parent, lower, upper, u) -> U inside the box (``u``: uniforms, for
# ``reinit``): only coordinates outside change, and an exact clip ends each (no ulp outside).


def _exact(U: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    return np.minimum(np.maximum(U, lower), upper)


def bounds_reinit(U, parent, lower, upper, u: np.ndarray) -> np.ndarray:
    """Outside coordinates get a fresh uniform value in the box (as scipy's DE): diversity kept."""
    out = (U < lower) | (U > upper)
    if not out.any():
        return U
    # lower + u * width >= lower exactly (u >= 0), so only the upper face needs a guard
    return np.minimum(np.where(out, lower + u * (upper - lower), U), upper)


def bounds_clip(U, parent, lower, upper, u=None) -> np.ndarray:
    """Project onto the box. Piles candidates up on the faces of the box."""
    return _exact(U, lower, upper)


def bounds_reflect(U, parent, lower, upper, u=None) -> np.ndarray:
    """Mirror at the violated face, folded again if a large step crosses the whole box."""
    out = (U < lower) | (U > upper)
    if not out.any():
        return U
    width = upper - lower
    y = np.mod(U - lower, 2.0 * width)
    y = np.where(y > width, 2.0 * width - y, y)
    return _exact(np.where(out, lower + y, U), lower, upper)


def bounds_midpoint(U, parent, lower, upper, u=None) -> np.ndarray:
    """Half way between the parent (inside the box) and the violated face."""
    below, above = U < lower, U > upper
    if not (below.any() or above.any()):
        return U
    U = np.where(below, 0.5 * (parent + lower), U)
    U = np.where(above, 0.5 * (parent + upper), U)
    return _exact(U, lower, upper)


BOUNDS_RULES: dict[str, Callable[..., np.ndarray]] = {
    "reinit": bounds_reinit,
    "clip": bounds_clip,
    "reflect": bounds_reflect,
    "midpoint": bounds_midpoint,
}
