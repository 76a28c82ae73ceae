"""The GA's two mutation operators for a bounded problem (``optimizer.mutation``):
``adaptfeasible`` (default), MATLAB's ``mutationadaptfeasible`` for bound constraints, and
``scaled_halving``, the project's earlier operator (docs/optimizers.md, "The mutation").
"""

from __future__ import annotations

import numpy as np

#: MATLAB's binding tolerance for bounds in ``mutationadaptfeasible``:
#: ``max(sqrt(eps), TolCon)`` with ``gaoptimset``'s default ``TolCon = 1e-6``.
ACTIVE_TOL = max(float(np.sqrt(np.finfo(float).eps)), 1e-6)


def _diagonal(rng: np.random.Generator, n: int, dim: int, p: float) -> np.ndarray:
    """The basis' diagonal, ``±p`` with random signs, ``(n, dim)``."""
    diagonal = p * np.sign(rng.random((n, dim)) - 0.5)
    if np.any(diagonal == 0.0):  # a draw of exactly 0.5: MATLAB draws one sign for them
        diagonal[diagonal == 0.0] = p * np.sign(0.5 - rng.random())
    return diagonal


def box_directions(
    X: np.ndarray,
    step: float,
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    tol: float = ACTIVE_TOL,
) -> tuple[np.ndarray, np.ndarray]:
    """MATLAB's ``boxdirections`` with a mesh-adaptive (MADS) basis, per row of ``X``:
    ``(basis, active)``. ``basis[i]`` (directions as columns) is ``P L P^T``, ``P`` a random
    permutation, ``L`` lower-triangular with ``±p`` on the diagonal and
    ``round((p + 1) U - 0.5)`` below, ``p = 1/sqrt(step)``. ``active[i, j]``: coordinate ``j``
    within ``tol`` (parameter units) of a bound (the tangent cone's unit vectors)."""
    n, dim = X.shape
    active = (np.abs(X - lower) <= tol) | (np.abs(X - upper) <= tol)
    p = 1.0 / np.sqrt(step)
    w = (p + 1.0) * rng.random((n, dim, dim)) - 0.5
    below = np.tril(np.sign(w) * np.floor(np.abs(w) + 0.5), -1)  # MATLAB's round
    diagonal = _diagonal(rng, n, dim, p)
    L = below + diagonal[:, :, None] * np.eye(dim)
    order = np.argsort(rng.random((n, dim)), axis=1)  # one random permutation per row
    rows = np.arange(n)[:, None, None]
    return L[rows, order[:, :, None], order[:, None, :]], active


def trial_directions(
    basis: np.ndarray, active: np.ndarray, order: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each parent's signed directions in trial order, ``(trials, valid)`` (``valid`` false
    for the padding). As in MATLAB the slots are every basis column twice, then every tangent
    direction twice, padded to ``4 d``; ``order[i]`` lists slots in trial order. The sign
    belongs to the trial's POSITION ``k``, not to its slot (``+`` for ``k < d``, ``-`` below
    ``2 d``, ``+`` below ``2 d + nt``, ``-`` after): a direction may never meet both signs."""
    n, dim, _ = basis.shape
    nt = active.sum(axis=1)[:, None]
    # direction table per parent: columns 0 .. d-1 the basis, d .. 2d-1 the unit vectors
    table = np.concatenate([basis, np.broadcast_to(np.eye(dim), (n, dim, dim))], axis=2)
    r = np.arange(2 * dim)
    active_first = np.argsort(~active, axis=1, kind="stable")  # active coordinates first
    tangent_cols = dim + np.take_along_axis(active_first, r % np.maximum(nt, 1), axis=1)
    slot_cols = np.concatenate([np.broadcast_to(r % dim, (n, 2 * dim)), tangent_cols], axis=1)
    cols = np.take_along_axis(slot_cols, order, axis=1)  # table column of each trial
    trials = table[np.arange(n)[:, None], :, cols]  # (n, 4d, d)
    k = np.arange(4 * dim)[None, :]
    signs = np.where((k < dim) | ((k >= 2 * dim) & (k < 2 * dim + nt)), 1.0, -1.0)
    return signs[:, :, None] * trials, k < 2 * (dim + nt)


def trial_order(active: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Per parent, a random permutation of the ``2 (d + nt)`` real slots, then the padding."""
    n, dim = active.shape
    nt = active.sum(axis=1)[:, None]
    real = np.arange(4 * dim)[None, :] < 2 * (dim + nt)
    return np.argsort(np.where(real, rng.random((n, 4 * dim)), np.inf), axis=1, kind="stable")


def first_feasible(
    X: np.ndarray,
    step: float,
    trials: np.ndarray,
    valid: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> np.ndarray:
    """Per row, ``X[i] + step trials[i, k]`` for the first ``k`` inside the box, else ``X[i]``."""
    mutants = X[:, None, :] + step * trials
    inside = valid & np.all((mutants >= lower) & (mutants <= upper), axis=2)
    first = np.argmax(inside, axis=1)
    chosen = mutants[np.arange(len(X)), first]
    return np.where(inside.any(axis=1)[:, None], chosen, X)


def mutationadaptfeasible(
    population: np.ndarray,
    parents: np.ndarray,
    step: float,
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    tol: float = ACTIVE_TOL,
    engine: str = "numba",
) -> np.ndarray:
    """MATLAB's adaptive-feasible mutation for a box: one child inside it per row index of
    ``parents`` (``step`` in parameter units), by :mod:`vpid_ga.fused` or, ``engine="numpy"``,
    the reference above (identical children, tested)."""
    X = population[parents]
    if engine == "numpy":
        basis, active = box_directions(X, step, lower, upper, rng, tol)
        trials, valid = trial_directions(basis, active, trial_order(active, rng))
        return first_feasible(X, step, trials, valid, lower, upper)
    from .fused import children

    n, dim = X.shape
    below_u = rng.random((n, dim, dim))  # the draws of box_directions, then trial_order
    diagonal = _diagonal(rng, n, dim, 1.0 / np.sqrt(step))
    order_u = rng.random((n, dim))
    trial_u = rng.random((n, 4 * dim))
    return children(np.ascontiguousarray(X, dtype=float), float(step), lower, upper,
                    float(tol), below_u, diagonal, order_u, trial_u)


def mutation_scaled_halving(
    population: np.ndarray,
    parents: np.ndarray,
    step: float,
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    max_halvings: int = 60,
) -> np.ndarray:
    """The project's earlier operator: child = ``x + s step (upper - lower) d`` (``step``: a
    fraction of the box width), ``d`` uniform on ``[-1, 1]`` per coordinate turned into the
    tangent cone of the active bounds, ``s`` halved from 1 until the child is inside (after
    ``max_halvings``, the parent)."""
    X = population[parents]
    n, dim = X.shape
    width = upper - lower
    d = rng.uniform(-1.0, 1.0, size=(n, dim))
    # Tangent cone of the active bounds: at (within sqrt(eps) of) a face, a component pointing
    # out of the box is turned inwards, so shrinking the step always reaches a feasible child.
    tol = np.sqrt(np.finfo(float).eps) * width
    d = np.where((X <= lower + tol) & (d < 0) | (X >= upper - tol) & (d > 0), -d, d)
    move = step * width * d
    scale = np.ones((n, 1))
    for _ in range(max_halvings):
        child = X + scale * move
        bad = ~np.all((child >= lower) & (child <= upper), axis=1)
        if not bad.any():
            break
        scale[bad] *= 0.5
    else:
        child = np.where(bad[:, None], X, child)
    return np.minimum(np.maximum(child, lower), upper)


#: ``optimizer.mutation`` -> operator; both take ``(population, parents, step, lower, upper,
#: rng)`` and return one child per parent.
MUTATIONS = {
    "adaptfeasible": mutationadaptfeasible,
    "scaled_halving": mutation_scaled_halving,
}
