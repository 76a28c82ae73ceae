"""Profile-likelihood intervals: what one record determines, without the Cramér–Rao bound's
linearisation (classes and method: docs/estimators.md, profile-likelihood intervals).

``NLL(θ) = ½ Σ_k (r_k(θ) / σ_k)²`` (``σ`` from :meth:`Problem.residual_sigma`, floored at
``SIGMA_FLOOR`` times its group's rms); the 95 % interval is where ``2 (PL_j(t) − NLL(θ̂)) ≤
3.84``, ``PL_j(t)`` the least NLL with ``θ_j = t``.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..estimators import SIGMA_FLOOR
from ..problem import Problem
from .identifiability import cramer_rao, entry_sigma, informative, jacobian

#: χ²(0.95, 1): the profile threshold of a 95 % interval.
CHI2_95 = 3.841458820694124
#: A smallest/largest singular value ratio at or below this is a structural symmetry.
STRUCTURAL_RATIO = 1e-6
#: Constrained fits a profile takes per interval end, for the estimate of its cost (a few
#: doublings out from the estimate, then the root search).
FITS_PER_END = 10


class ProfileTooSlowError(RuntimeError):
    """The profile would take longer than the time it was given (its estimate, in s)."""

    def __init__(self, estimate_s: float, limit_s: float) -> None:
        super().__init__(f"the profile would take about {estimate_s:.0f} s (limit {limit_s:g} "
                         "s)")
        self.estimate_s, self.limit_s = estimate_s, limit_s


def structural_symmetry(problem: Problem, x: np.ndarray | None = None,
                        sigma: np.ndarray | None = None) -> tuple[float, np.ndarray | None]:
    """The smallest/largest singular value of the whitened Jacobian in log-parameters at
    ``x`` (the truth by default), and the direction (unit vector in relative changes) of a
    structural symmetry when the ratio is at most :data:`STRUCTURAL_RATIO`, else ``None``.
    ``sigma``: the noise per group or entry (default the problem's ``residual_sigma``)."""
    x = np.asarray(problem.x_true if x is None else x, dtype=float)
    given = problem.residual_sigma() if sigma is None else sigma
    if given is None:
        raise ValueError("the problem states no noise sigma (residual_sigma)")
    groups = np.asarray(problem.fisher_groups(), dtype=int)
    per = entry_sigma(np.asarray(given, dtype=float), groups)
    if per is None:
        raise ValueError("the noise sigma has neither a per-group nor a per-entry shape")
    kept = informative(per, groups)
    J = jacobian(problem, x)[kept] / per[kept][:, None]
    _, s, vt = np.linalg.svd(J * x[None], full_matrices=False)
    ratio = float(s[-1] / s[0]) if s[0] > 0 else 0.0
    return ratio, (vt[-1] if ratio <= STRUCTURAL_RATIO else None)


class _Likelihood:
    """``NLL`` and the whitened residuals of a problem, in coordinates scaled by ``centre``
    (the truth by default, else a start such as an identified vector)."""

    def __init__(self, problem: Problem, centre: np.ndarray | None = None,
                 sigma: np.ndarray | None = None) -> None:
        sigma = problem.residual_sigma() if sigma is None else sigma
        centre = problem.x_true if centre is None else np.asarray(centre, dtype=float)
        if sigma is None or centre is None:
            raise ValueError("profiles need a start (the truth or an estimate) and the noise "
                             "sigma (residual_sigma, or estimated from the residuals)")
        groups = np.asarray(problem.fisher_groups(), dtype=int)
        per = entry_sigma(np.asarray(sigma, float), groups)
        if per is None:
            raise ValueError("the problem's residual_sigma has neither a per-group nor a "
                             "per-entry shape")
        floor = np.array([np.sqrt(np.mean(per[groups == g] ** 2))
                          for g in range(int(groups.max()) + 1)])[groups] * SIGMA_FLOOR
        kept = informative(per, groups)
        per = np.maximum(per, floor)
        self.problem, self.kept, self.sigma = problem, kept, per[kept]
        self.centre = centre
        self.scale = np.where(np.abs(centre) > 0, np.abs(centre), problem.bounds.width)
        b = problem.bounds
        self.lo, self.hi = b.lower / self.scale, b.upper / self.scale
        self.deadline: float | None = None  # perf_counter time past which a fit gives up
        self.limit_s = 0.0

    def residuals(self, z: np.ndarray) -> np.ndarray:
        r = np.asarray(self.problem.fisher_residuals((z * self.scale)[None]), float)[0]
        w = r[self.kept] / self.sigma
        return np.where(np.isfinite(w), w, 1e6)

    def nll(self, z: np.ndarray) -> float:
        return 0.5 * float(np.sum(self.residuals(z) ** 2))

    def fit(self, z0: np.ndarray, fixed: int | None = None, value: float = 0.0
            ) -> tuple[np.ndarray, float]:
        """The least NLL from ``z0``, with coordinate ``fixed`` held at ``value``."""
        from scipy.optimize import least_squares

        if self.deadline is not None and time.perf_counter() > self.deadline:
            raise ProfileTooSlowError(time.perf_counter() - self.deadline + self.limit_s * 2,
                                 self.limit_s)

        free = np.ones(z0.size, bool)
        if fixed is not None:
            free[fixed] = False

        def full(zf: np.ndarray) -> np.ndarray:
            z = z0.copy()
            z[free] = zf
            if fixed is not None:
                z[fixed] = value
            return z

        lo, hi = self.lo[free], self.hi[free]
        start = np.clip(z0[free], lo + 1e-12 * (hi - lo), hi - 1e-12 * (hi - lo))
        sol = least_squares(lambda zf: self.residuals(full(zf)), start, bounds=(lo, hi),
                            method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400)
        z = full(sol.x)
        return z, self.nll(z)


def profile_intervals(problem: Problem, crb: dict[str, Any] | None = None,
                      max_steps: int = 12, start: np.ndarray | None = None,
                      sigma: np.ndarray | None = None,
                      rel_sd: np.ndarray | None = None,
                      limit_s: float | None = None) -> dict[str, Any]:
    """95 % profile-likelihood intervals of every parameter of ``problem`` (one instance):
    ``names``, ``estimate``, ``lower``, ``upper`` (physical; an open end ``None``),
    ``classification``, ``symmetry_ratio``. ``crb``: its Cramér–Rao bounds if computed
    (the first steps; the symmetry test). Without a truth: ``start`` (an identified vector),
    ``sigma`` per group estimated from the residuals and ``rel_sd`` (the first steps).
    ``limit_s``: :class:`ProfileTooSlowError` when the first fit says it would take longer
    (``2 d FITS_PER_END`` fits), or once it has run twice that long."""
    from scipy.optimize import brentq

    lik = _Likelihood(problem, start, sigma)
    began = time.perf_counter()
    z_hat, nll_hat = lik.fit(np.asarray(lik.centre, float) / lik.scale)
    if limit_s is not None:
        estimate = (time.perf_counter() - began) * 2 * z_hat.size * FITS_PER_END
        if estimate > limit_s:
            raise ProfileTooSlowError(estimate, limit_s)
        lik.deadline, lik.limit_s = began + 2 * limit_s, limit_s
    if start is None:
        crb = crb if crb is not None else cramer_rao(problem)
        cond = None if crb is None else crb["condition_number"]
        ratio = 0.0 if cond is None or not np.isfinite(cond) else 1.0 / cond
        # the direction needs the singular vectors: a second decomposition, when symmetric
        direction = structural_symmetry(problem)[1] if ratio <= STRUCTURAL_RATIO else None
        rel_sd = (np.asarray(crb["crb_percent"]) / 100.0 if crb is not None
                  else np.full(z_hat.size, 0.01))
    else:
        ratio, direction = structural_symmetry(problem, z_hat * lik.scale, sigma)
        rel_sd = np.full(z_hat.size, 0.01) if rel_sd is None else np.asarray(rel_sd, float)
        rel_sd = np.where(np.isfinite(rel_sd) & (rel_sd > 0), rel_sd, 0.01)
    out: dict[str, Any] = {"names": list(problem.bounds.names),
                           "estimate": (z_hat * lik.scale).tolist(),
                           "lower": [], "upper": [], "classification": [],
                           "symmetry_ratio": ratio}
    for j in range(z_hat.size):
        lower, upper = (_end(lik, z_hat, nll_hat, j, sign, edge, max(rel_sd[j], 1e-6),
                             max_steps, brentq) for sign, edge in ((-1, lik.lo[j]), (1, lik.hi[j])))
        out["lower"].append(None if lower is None else float(lower * lik.scale[j]))
        out["upper"].append(None if upper is None else float(upper * lik.scale[j]))
        if lower is not None and upper is not None:
            kind = "identifiable"
        elif direction is not None and abs(direction[j]) > 0.1:
            kind = "structurally non-identifiable"
        else:
            kind = "practically non-identifiable"
        out["classification"].append(kind)
    return out


def _end(lik: _Likelihood, z_hat: np.ndarray, nll_hat: float, j: int, sign: int,
         edge: float, step: float, max_steps: int, brentq: Any) -> float | None:
    """Where the profile of coordinate ``j`` crosses the threshold on side ``sign``, or
    ``None`` when it reaches ``edge`` (or gives up after ``max_steps`` doublings) below it."""
    z_prev, t_prev = z_hat.copy(), z_hat[j]
    for k in range(max_steps):
        t = z_hat[j] + sign * step * 2.0**k
        at_edge = (t - edge) * sign >= 0
        t = edge if at_edge else t
        z, nll = lik.fit(z_prev, j, t)
        if 2.0 * (nll - nll_hat) >= CHI2_95:
            def excess(s: float, z_start: np.ndarray = z_prev) -> float:
                return 2.0 * (lik.fit(z_start, j, s)[1] - nll_hat) - CHI2_95

            return float(brentq(excess, t_prev, t, xtol=1e-6 * abs(z_hat[j]) + 1e-12))
        if at_edge:
            return None
        z_prev, t_prev = z, t
    return None
