"""Intervals of identified parameters on a record without a truth (a measured record).

For ``x̂`` (physical units): each residual group's noise ``σ̂_g² = RSS_g / (m_g − d m_g / m)``
(:meth:`Problem.fisher_groups`), the Gauss–Newton covariance ``(Jᵀ W J)⁻¹`` with ``J`` the
central-difference Jacobian of :meth:`Problem.fisher_residuals` and ``W = diag(1 / σ̂_g²)``,
and ``x̂_j ± 1.96 sqrt(cov_jj)`` (unbounded in a direction the record does not determine); it
assumes white residuals. ``robust`` is the sandwich ``A⁻¹ B A⁻¹`` with ``B`` Andrews and
Monahan's prewhitened Newey–West estimate, each variance the larger of it and the plain one
(what and why: docs/estimators.md, fit diagnostics and intervals that survive model error).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..problem import Problem
from .identifiability import jacobian

#: The two-sided 95 % normal quantile (scipy.stats.norm.ppf(0.975)).
Z95 = 1.959963984540054
#: The largest singular value of the prewhitening VAR(1) (Andrews and Monahan 1992): a
#: persistence past it is taken as this, so that the recolouring ``(I − Φ)⁻¹`` stays finite.
MAX_AR = 0.97
#: A singular value of the whitened Jacobian (in relative parameter changes) below this
#: fraction of the largest is a direction the record does not determine.
UNDETERMINED_RATIO = 1e-9


def group_sigma(residuals: np.ndarray, groups: np.ndarray, dim: int) -> np.ndarray:
    """``σ̂_g`` of each residual group from residuals at an estimate (see the module),
    ``(groups,)``; ``RSS_g / m_g`` where the degrees of freedom would leave none."""
    r = np.asarray(residuals, dtype=float).reshape(-1)
    groups = np.asarray(groups, dtype=int).reshape(-1)
    m = r.size
    out = np.empty(int(groups.max()) + 1 if groups.size else 0)
    for g in range(out.size):
        rg = r[groups == g]
        dof = rg.size - dim * rg.size / m
        out[g] = math.sqrt(float(rg @ rg) / (dof if dof > 0 else max(rg.size, 1)))
    return out


def jacobian_intervals(problem: Problem, x: np.ndarray) -> dict[str, Any] | None:
    """95 % intervals of the parameters at ``x`` (see the module), or ``None`` when a
    residual at ``x`` is not finite or all are zero: ``lower``, ``upper``, ``se`` (physical
    units; ``None``: undetermined, unbounded), ``sigma`` (``σ̂`` per group, the residuals'
    units), ``dof`` (``m − d``) and the same under ``robust``."""
    x = np.asarray(x, dtype=float).reshape(-1)
    groups = np.asarray(problem.fisher_groups(), dtype=int).reshape(-1)
    r = np.asarray(problem.fisher_residuals(x[None]), dtype=float)[0]
    if r.shape != groups.shape or not np.all(np.isfinite(r)):
        return None
    sigma = group_sigma(r, groups, x.size)
    if not np.any(sigma > 0):
        return None
    per = sigma[groups]
    kept = per > 0
    J = jacobian(problem, x)
    if not np.all(np.isfinite(J)):
        return None
    scale = np.where(x != 0, np.abs(x), 1.0)
    Jw = J[kept] / per[kept][:, None] * scale[None]  # whitened, relative parameters
    e = r[kept] / per[kept]
    u, s, vt = np.linalg.svd(Jw, full_matrices=False)
    se = np.full(x.size, math.inf)
    se_hac = np.full(x.size, math.inf)
    lags = 0
    if s.size and s[0] > 0:
        good = s > UNDETERMINED_RATIO * s[0]
        # covariance in relative coordinates from the determined directions only
        a_inv = (vt[good].T / s[good] ** 2) @ vt[good]
        se_rel = np.sqrt(np.maximum(np.diag(a_inv), 0.0))
        blind = np.any(np.abs(vt[~good]) > 1e-3, axis=0) if np.any(~good) else \
            np.zeros(x.size, bool)
        se = np.where(blind, math.inf, se_rel * scale)
        scores = Jw * e[:, None]
        variances = []
        for prewhiten in (True, False):
            meat, n_lags = hac_covariance(scores, groups[kept], prewhiten=prewhiten)
            variances.append(np.diag(a_inv @ meat @ a_inv))
            lags = lags or n_lags  # the prewhitened estimate's, which the report names
        hac_var = np.maximum(*variances)  # the larger of the two (see the module)
        se_hac = np.where(blind, math.inf, np.sqrt(np.maximum(hac_var, 0.0)) * scale)
    return {"method": "jacobian", "assumes": "white residuals", "level": 0.95, **_ends(x, se),
            "sigma": sigma.tolist(), "dof": int(r.size - x.size),
            "robust": {"method": "hac", "kernel": "bartlett", "prewhitened": "var1 or none",
                       "lags": int(lags), "level": 0.95, **_ends(x, se_hac)}}


def _ends(x: np.ndarray, se: np.ndarray) -> dict[str, list[float | None]]:
    """The 95 % interval of ``x`` with standard errors ``se`` (``None``: unbounded)."""
    return {"lower": _finite_or_none(x - Z95 * se), "upper": _finite_or_none(x + Z95 * se),
            "se": _finite_or_none(se)}


def andrews_lags(rho: float, t: int) -> int:
    """Andrews' (1991) automatic Bartlett bandwidth for an AR(1) with lag-1 autocorrelation
    ``rho`` over ``t`` time points, ``1.1447 (α t)^{1/3}``, ``α = 4ρ²/((1−ρ)²(1+ρ)²)``
    (``|ρ|`` capped at 0.99), between 1 and ``t // 4``."""
    rho = float(np.clip(rho, -0.99, 0.99)) if math.isfinite(rho) else 0.0
    alpha = 4 * rho**2 / ((1 - rho) ** 2 * (1 + rho) ** 2)
    return int(max(1, min(max(t // 4, 1), math.ceil(1.1447 * (alpha * t) ** (1 / 3)))))


def hac_covariance(scores: np.ndarray, groups: np.ndarray, lags: int | None = None,
                   prewhiten: bool = True) -> tuple[np.ndarray, int]:
    """The long-run covariance ``B`` of ``scores`` ``(m, d)`` (the entries at one time
    position summed first) and its lags: Newey–West over a VAR(1)'s innovations, recoloured
    (``prewhiten``), or over the scores themselves (statsmodels' ``S_hac_simple``).
    ``lags=None``: :func:`andrews_lags` of the pooled lag-1 autocorrelation."""
    scores = np.asarray(scores, dtype=float)
    groups = np.asarray(groups, dtype=int).reshape(-1)
    pos = np.empty(groups.size, dtype=int)  # each entry's place (time position) in its group
    for g in np.unique(groups):
        mine = groups == g
        pos[mine] = np.arange(int(np.sum(mine)))
    t = int(pos.max()) + 1 if pos.size else 0
    S = np.zeros((t, scores.shape[1]))
    np.add.at(S, pos, scores)
    colour = None
    if prewhiten and t > 3:
        phi = var1(S)
        S = S[1:] - S[:-1] @ phi.T
        colour = np.linalg.inv(np.eye(phi.shape[0]) - phi)
    if lags is None:
        num = float(np.sum(S[1:] * S[:-1]))
        den = float(np.sum(S * S))
        lags = andrews_lags(num / den if den > 0 else 0.0, S.shape[0])
    w = 1.0 - np.abs(np.arange(-lags, lags + 1)) / (lags + 1)
    B = S.T @ _convolve_same(S, w)
    if colour is not None:
        B = colour @ B @ colour.T
    return (B + B.T) / 2, lags


def var1(S: np.ndarray) -> np.ndarray:
    """The least-squares VAR(1) coefficient ``Φ`` ``(d, d)`` of the rows ``s_t = Φ s_{t−1} +
    u_t`` of ``S`` ``(t, d)``, its singular values capped at :data:`MAX_AR` (Andrews and
    Monahan 1992); columns that never move (undetermined directions) get none."""
    coef = np.linalg.lstsq(S[:-1], S[1:], rcond=None)[0].T
    if not np.all(np.isfinite(coef)):
        return np.zeros_like(coef)
    u, sv, vt = np.linalg.svd(coef)
    return (u * np.minimum(sv, MAX_AR)) @ vt


def _convolve_same(S: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Each column of ``S`` ``(t, d)`` convolved with the odd-length kernel ``w``, the
    central ``t`` samples (``fftconvolve(..., mode="same")``) by numpy's FFT: importing
    scipy.signal costs about a second of a run's time limit."""
    t, k = S.shape[0], w.size
    n = 1 << max(1, int(t + k - 1 - 1).bit_length())
    full = np.fft.irfft(np.fft.rfft(S, n, axis=0) * np.fft.rfft(w, n)[:, None], n, axis=0)
    return full[(k - 1) // 2:(k - 1) // 2 + t]


def _finite_or_none(a: np.ndarray) -> list[float | None]:
    return [float(v) if math.isfinite(v) else None for v in a]
