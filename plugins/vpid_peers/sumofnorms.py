"""The local model of ``F = sum_g ||r_g||`` (the vehicle's Eq. 3; one group is a sum of
squares), ``M(p) = sum_g ||r_g + J_g p||``, from the per-group Gram quantities (a step costs
``O(groups n^3)`` whatever the number of residuals), and its IRLS step: with ``w_g =
1/||r_g||`` the weighted sum of squares has the gradient of ``F``.
"""

from __future__ import annotations

import numpy as np


def sum_of_norms(R: np.ndarray, groups: np.ndarray, n_groups: int) -> np.ndarray:
    """``F = sum_g ||r_g||`` of each row of ``R`` (n, m); inf where a residual is not finite."""
    R = np.atleast_2d(R)
    F = np.stack([np.sqrt(np.sum(R[:, groups == g] ** 2, axis=1)) for g in range(n_groups)],
                 axis=1).sum(axis=1)
    F[~np.isfinite(F)] = np.inf
    return F


def gradient(r: np.ndarray, J: np.ndarray, groups: np.ndarray, n_groups: int) -> np.ndarray:
    """The gradient of ``F``, ``sum_g J_g^T r_g / ||r_g||`` (a zero-norm group adds nothing)."""
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
    """``argmin 1/2 p^T (H + diag(damping)) p + g^T p`` over ``lower <= p <= upper`` (``lower
    <= 0 <= upper``) by a primal active-set method from 0 (Nocedal and Wright, 16.3): step
    towards the free coordinates' minimiser until a face blocks, release the fixed coordinate
    whose multiplier has the wrong sign, until none has."""
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
