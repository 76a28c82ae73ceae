"""The GA's two mutation operators for a bounded problem, chosen by ``optimizer.mutation``.

``adaptfeasible`` (the default): the structure of MATLAB's ``mutationadaptfeasible`` for
bound constraints, as public derivatives of MathWorks' file show it (see docs/optimizers.md).
For each parent ``x``:

1. :func:`box_directions`: a random mesh-adaptive basis of ``dim`` directions (a random
   lower-triangular matrix with ``±1/sqrt(step)`` on the diagonal and integers in
   ``0 ... 1/sqrt(step)`` below it, rows and columns permuted together), plus the tangent
   cone of the active bounds (the unit vector of every coordinate within ``tol`` of a bound);
2. :func:`trial_directions`: every direction twice, in a random order, with MATLAB's signs
   (see there: the sign belongs to the trial's position, not to the direction);
3. :func:`first_feasible`: the child is ``x + step * d`` for the first trial ``d`` that stays
   inside the box, else the parent itself. No scaling by the box width, no halving.

``scaled_halving``: the project's earlier operator, :func:`mutation_scaled_halving`: a dense
random direction scaled by ``step`` times the box width, halved until the child is inside.
"""

from __future__ import annotations

import numpy as np

#: MATLAB's binding tolerance for bounds in ``mutationadaptfeasible``:
#: ``max(sqrt(eps), TolCon)`` with ``gaoptimset``'s default ``TolCon = 1e-6``.
ACTIVE_TOL = max(float(np.sqrt(np.finfo(float).eps)), 1e-6)


def _matlab_round(values: np.ndarray) -> np.ndarray:
    """MATLAB's ``round`` element-wise (half away from zero)."""
    return np.sign(values) * np.floor(np.abs(values) + 0.5)


def box_directions(
    x: np.ndarray,
    step: float,
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    tol: float = ACTIVE_TOL,
) -> tuple[np.ndarray, np.ndarray]:
    """MATLAB's ``boxdirections`` with a mesh-adaptive (MADS) basis.

    Returns ``(basis, tangent)``, directions as columns: ``basis`` is ``dim x dim``,
    ``P L P^T`` for a random permutation ``P`` and a lower-triangular ``L`` whose diagonal is
    ``±p`` (random signs) and whose entries below the diagonal are
    ``round((p + 1) U - 0.5)``, ``U ~ U(0, 1)``, i.e. integers in ``0 ... round(p)``, with
    ``p = 1/sqrt(step)``; ``tangent`` holds the unit vectors of the coordinates whose lower or
    upper bound is active (``|x - bound| <= tol``, in the parameters' units)."""
    dim = x.size
    active = (np.abs(x - lower) <= tol) | (np.abs(x - upper) <= tol)
    tangent = np.eye(dim)[:, active]
    p = 1.0 / np.sqrt(step)
    below = np.tril(_matlab_round((p + 1.0) * rng.random((dim, dim)) - 0.5), -1)
    diagonal = p * np.sign(rng.random(dim) - 0.5)
    if np.any(diagonal == 0.0):  # a draw of exactly 0.5: MATLAB draws one sign for all of them
        diagonal[diagonal == 0.0] = p * np.sign(0.5 - rng.random())
    order = rng.permutation(dim)
    basis = (below + np.diag(diagonal))[np.ix_(order, order)]
    return basis, tangent


def trial_directions(basis: np.ndarray, tangent: np.ndarray, order: np.ndarray) -> np.ndarray:
    """The signed search directions in the order they are tried, one per row.

    As in MATLAB: the list of slots is every basis direction twice, then every tangent
    direction twice; the signs are ``+`` for the first ``n_basis`` trials, ``-`` for the next
    ``n_basis``, ``+`` for the next ``n_tangent``, ``-`` for the last ``n_tangent``; trial ``k``
    uses slot ``order[k]`` (``order`` a permutation of ``2 (n_basis + n_tangent)``) with the
    sign of position ``k``. So a direction is not always tried with both signs: both of its
    slots may fall on positions of the same sign."""
    n_basis, n_tangent = basis.shape[1], tangent.shape[1]
    directions = np.hstack([basis, tangent])
    slots = np.concatenate([np.arange(n_basis), np.arange(n_basis),
                            n_basis + np.arange(n_tangent), n_basis + np.arange(n_tangent)])
    signs = np.concatenate([np.ones(n_basis), -np.ones(n_basis),
                            np.ones(n_tangent), -np.ones(n_tangent)])
    return signs[:, None] * directions[:, slots[order]].T


def first_feasible(
    x: np.ndarray, step: float, trials: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """``x + step * trials[k]`` for the first ``k`` that lies inside ``[lower, upper]``
    (bounds included, no tolerance), else a copy of ``x``."""
    mutants = x + step * trials
    inside = np.flatnonzero(np.all((mutants >= lower) & (mutants <= upper), axis=1))
    return mutants[inside[0]].copy() if inside.size else x.copy()


def mutationadaptfeasible(
    population: np.ndarray,
    parents: np.ndarray,
    step: float,
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    tol: float = ACTIVE_TOL,
) -> np.ndarray:
    """MATLAB's adaptive-feasible mutation for a box: one child per entry of ``parents``
    (row indices into ``population``). ``step`` is in the parameters' own units; each child
    is inside the box. Per parent, ``rng`` draws the basis (``dim x dim`` and ``dim``
    uniforms, a permutation of ``dim``) and then the trial order (a permutation)."""
    children = np.empty((len(parents), population.shape[1]))
    for i, parent in enumerate(parents):
        x = population[parent]
        basis, tangent = box_directions(x, step, lower, upper, rng, tol)
        order = rng.permutation(2 * (basis.shape[1] + tangent.shape[1]))
        children[i] = first_feasible(x, step, trial_directions(basis, tangent, order),
                                     lower, upper)
    return children


def mutation_scaled_halving(
    population: np.ndarray,
    parents: np.ndarray,
    step: float,
    lower: np.ndarray,
    upper: np.ndarray,
    rng: np.random.Generator,
    max_halvings: int = 60,
) -> np.ndarray:
    """The project's earlier operator: child = ``x + s * step * (upper - lower) * d``.

    ``d`` is a random direction (uniform on ``[-1, 1]`` per coordinate) in the tangent cone of
    the active bounds (a component that would leave a face the parent sits on is reversed),
    and ``s`` starts at 1 and is halved until the child is inside the box. After
    ``max_halvings`` halvings the child is the parent itself (practically never). The result
    is clipped exactly so rounding never leaves the box. ``step`` is a fraction of the box
    width."""
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
