"""The local model of an objective that is a sum of group norms, ``F = sum_g ||r_g||``.

The vehicle's Eq. 3 is such a sum (one norm per measured channel, over a constant); a plain
sum of squares is the case of one group (``F = ||r||``, minimised where ``||r||^2`` is). With
residuals ``r`` and their Jacobian ``J`` at a point, the linearised objective of a step ``p``
is ``M(p) = sum_g ||r_g + J_g p||``, convex in ``p``. Everything here works on the per-group
Gram quantities ``A_g = J_g^T J_g``, ``b_g = J_g^T r_g``, ``c_g = r_g^T r_g``, so a step costs
``O(groups n^3)`` whatever the number of residuals.

Iteratively reweighted least squares (IRLS): weighting group ``g`` by ``w_g = 1/||r_g||``
turns ``F`` into the weighted sum of squares ``1/2 sum_g w_g ||r_g||^2``, whose gradient
``sum_g w_g J_g^T r_g`` equals the gradient of ``F``; so a point where the weighted
least-squares problem with its own weights is stationary is a stationary point of ``F``.
"""

from __future__ import annotations

import numpy as np


def group_norms(R: np.ndarray, groups: np.ndarray, n_groups: int) -> np.ndarray:
    """``||r_g||`` of each row of ``R`` (n, m) and each group: shape (n, n_groups)."""
    R = np.atleast_2d(R)
    out = np.empty((R.shape[0], n_groups))
    for g in range(n_groups):
        out[:, g] = np.sqrt(np.sum(R[:, groups == g] ** 2, axis=1))
    return out


def sum_of_norms(R: np.ndarray, groups: np.ndarray, n_groups: int) -> np.ndarray:
    """``F = sum_g ||r_g||`` of each row of ``R``; inf where a residual is not finite."""
    F = group_norms(R, groups, n_groups).sum(axis=1)
    F[~np.isfinite(F)] = np.inf
    return F


def gradient(r: np.ndarray, J: np.ndarray, groups: np.ndarray, n_groups: int) -> np.ndarray:
    """The gradient of ``F`` for residuals ``r`` (m,) with Jacobian ``J`` (m, n):
    ``sum_g J_g^T r_g / ||r_g||`` (a group with a zero norm contributes nothing)."""
    grad = np.zeros(J.shape[1])
    for g in range(n_groups):
        idx = groups == g
        norm = float(np.linalg.norm(r[idx]))
        if norm > 0:
            grad += J[idx].T @ r[idx] / norm
    return grad


class LocalModel:
    """``M(p) = sum_g ||r_g + J_g p||`` around a point, from its Gram quantities."""

    def __init__(self, r: np.ndarray, J: np.ndarray, groups: np.ndarray, n_groups: int) -> None:
        n = J.shape[1]
        self.A = np.empty((n_groups, n, n))
        self.b = np.empty((n_groups, n))
        self.c = np.empty(n_groups)
        for g in range(n_groups):
            idx = groups == g
            Jg, rg = J[idx], r[idx]
            self.A[g] = Jg.T @ Jg
            self.b[g] = Jg.T @ rg
            self.c[g] = rg @ rg

    def squares(self, p: np.ndarray) -> np.ndarray:
        """``||r_g + J_g p||^2`` per group (clipped at 0 against rounding)."""
        q = self.c + 2.0 * (self.b @ p) + np.einsum("i,gij,j->g", p, self.A, p)
        return np.maximum(q, 0.0)

    def value(self, p: np.ndarray) -> float:
        """``M(p)``."""
        return float(np.sqrt(self.squares(p)).sum())

    def irls_system(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The normal equations ``H s = -g`` of the weighted least squares with weights
        ``w_g = 1/||r_g + J_g p||`` (frozen at ``p``); the step ``s`` is from 0, not from
        ``p``. At ``p = 0``, ``g`` is the gradient of ``F``."""
        w = 1.0 / np.sqrt(np.maximum(self.squares(p), np.finfo(float).tiny))
        return np.einsum("g,gij->ij", w, self.A), w @ self.b


def box_step(
    H: np.ndarray, g: np.ndarray, damping: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """``argmin 1/2 p^T (H + D) p + g^T p`` over ``lower <= p <= upper`` (``D =
    diag(damping)``, ``H + D`` positive definite, ``lower <= 0 <= upper``).

    A primal active-set method (Nocedal and Wright, Numerical Optimization, 16.3) from the
    feasible point 0: minimise over the free coordinates, step towards that minimiser until a
    face blocks (that coordinate joins the working set), and at a subspace minimiser release
    the fixed coordinate whose multiplier has the wrong sign; stop when none has."""
    n = g.size
    M = H + np.diag(damping)
    p = np.zeros(n)
    fixed = ((lower >= 0) & (g > 0)) | ((upper <= 0) & (g < 0))  # on a face, pushed out
    for _ in range(10 * n + 10):
        free = ~fixed
        target = p.copy()
        if np.any(free):
            rhs = -g[free] - M[np.ix_(free, fixed)] @ p[fixed]
            try:
                target[free] = np.linalg.solve(M[np.ix_(free, free)], rhs)
            except np.linalg.LinAlgError:
                target[free] = np.linalg.lstsq(M[np.ix_(free, free)], rhs, rcond=None)[0]
        d = target - p
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(d < 0, (lower - p) / d, np.where(d > 0, (upper - p) / d, np.inf))
        room[fixed] = np.inf
        block = int(np.argmin(room))
        if room[block] < 1.0:
            p = p + max(room[block], 0.0) * d
            p[block] = lower[block] if d[block] < 0 else upper[block]
            fixed[block] = True
            continue
        p = target
        grad = M @ p + g
        wrong = fixed & (((p <= lower) & (grad < 0)) | ((p >= upper) & (grad > 0)))
        if not np.any(wrong):
            break
        fixed[int(np.argmax(np.where(wrong, np.abs(grad), -1.0)))] = False
    return np.clip(p, lower, upper)
