"""Identifiability: what a record design can determine, as Cramér–Rao bounds.

For residuals ``r(θ) = y - g(θ)`` with independent Gaussian noise of standard deviation ``σ_c``
in residual group (channel) ``c`` (or ``σ_k`` per entry, e.g. multiplicative noise; entries
with ``σ_k = 0`` carry no noise and no information and are left out), the Fisher information at
the truth is ``F = Jᵀ diag(1/σ²) J`` with ``J = ∂g/∂θ``, and any unbiased estimator has
covariance at least ``F⁻¹``. The bound is reported per parameter as a relative standard
deviation in percent, ``100 sqrt((F⁻¹)_jj) / |θ_j|``, and as the norm of those (comparable to a
norm of relative errors). ``J`` is a central-difference Jacobian of the residuals at the truth
(the reference cancels: it is the Jacobian of the clean responses). The singular values of
``J`` scaled by the true values and by ``σ`` show how many parameter combinations the record
pins down.

The noise convention is the problem's (:meth:`Problem.residual_sigma`), e.g. the
equivalent additive noise ``σ_c = level * rms(clean channel c)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..problem import Problem

#: Relative step of the central differences.
STEP = 1e-6


def jacobian(problem: Problem, x: np.ndarray, step: float = STEP) -> np.ndarray:
    """Central-difference Jacobian of the residuals at ``x``, shape ``(m, d)``; all ``2 d``
    points evaluated in one batch."""
    x = np.asarray(x, dtype=float)
    d = x.size
    h = step * np.where(x != 0, np.abs(x), 1.0)
    P = np.repeat(x[None], 2 * d, axis=0)
    P[np.arange(d), np.arange(d)] += h
    P[d + np.arange(d), np.arange(d)] -= h
    R = problem.residuals(P)
    return ((R[:d] - R[d:]) / (2 * h[:, None])).T


def entry_sigma(sigma: np.ndarray, groups: np.ndarray) -> np.ndarray | None:
    """The noise's sigma of each residual entry, from ``sigma`` given per group
    (``(groups,)``) or per entry (``(m,)``, e.g. multiplicative noise); ``None`` when its
    shape is neither, a value is negative or not finite, or no entry is noisy."""
    sigma = np.asarray(sigma, dtype=float).reshape(-1)
    if sigma.size == groups.size:
        out = sigma
    elif groups.size and sigma.size == int(groups.max()) + 1:
        out = sigma[groups]
    else:
        return None
    if not np.all(np.isfinite(out) & (out >= 0)) or not np.any(out > 0):
        return None
    return out


def _group_sigma(given: np.ndarray, per_entry: np.ndarray, groups: np.ndarray) -> list[float]:
    """Sigma per group as given, or the rms over each group's entries when given per
    entry."""
    ngroups = int(groups.max()) + 1
    if given.size == ngroups:
        return given.tolist()
    return [float(np.sqrt(np.mean(per_entry[groups == g] ** 2))) for g in range(ngroups)]


def cramer_rao(problem: Problem) -> dict[str, Any] | None:
    """Bounds at the truth (see the module), or ``None`` when the problem lacks the truth,
    residuals or a noise level. Keys: ``names``, ``crb_percent`` (per parameter),
    ``crb_norm_percent``, ``singular_values`` (of the scaled Jacobian, descending),
    ``condition_number``, ``sigma`` (per group; the rms over the group's entries when given
    per entry)."""
    x_true, sigma = problem.x_true, problem.residual_sigma()
    if x_true is None or sigma is None:
        return None
    groups = np.asarray(problem.residual_groups(), dtype=int)
    per_entry = entry_sigma(np.asarray(sigma, dtype=float), groups)
    if per_entry is None:
        return None
    J = jacobian(problem, x_true)
    kept = per_entry > 0  # noise-free samples (a multiplicative model at zero) carry none
    Jw = J[kept] / per_entry[kept][:, None]  # whitened
    fisher = Jw.T @ Jw
    try:
        cov = np.linalg.inv(fisher)
    except np.linalg.LinAlgError:
        cov = np.linalg.pinv(fisher)
    crb = 100.0 * np.sqrt(np.maximum(np.diag(cov), 0.0)) / np.abs(x_true)
    s = np.linalg.svd(Jw * x_true[None], compute_uv=False)
    return {
        "names": list(problem.bounds.names),
        "crb_percent": crb.tolist(),
        "crb_norm_percent": float(np.linalg.norm(crb)),
        "singular_values": s.tolist(),
        "condition_number": float(s[0] / s[-1]) if s[-1] > 0 else float("inf"),
        "sigma": _group_sigma(np.asarray(sigma, dtype=float).reshape(-1), per_entry, groups),
    }
