"""Identifiability: what a record design can determine, as Cramér–Rao bounds.

The Fisher information at the truth is ``F = Jᵀ diag(1/σ²) J`` (``J`` central differences of
:meth:`~vpid_bench.problem.Problem.fisher_residuals`, ``σ`` per group or entry from
:meth:`Problem.residual_sigma`); per parameter ``100 sqrt((F⁻¹)_jj) / |θ_j|`` (%) and their
norm. Entries at rounding level (:data:`ROUNDING`) are left out, and the bound is given again
with ``σ`` floored at :data:`FLOOR_FRACTIONS` of its group's rms (docs/estimators.md, the bound).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..problem import Problem, kept_instance

#: Relative step of the central differences.
STEP = 1e-6
#: An entry whose sigma is at most this fraction of its group's largest is rounding noise.
ROUNDING = 1e-12
#: The sigma floors of the sensitivity figures, as fractions of each group's rms sigma.
FLOOR_FRACTIONS = (0.0, 1e-3, 1e-2)


def jacobian(problem: Problem, x: np.ndarray, step: float = STEP) -> np.ndarray:
    """Central-difference Jacobian of the problem's ``fisher_residuals`` at ``x``, shape
    ``(m, d)``; all ``2 d`` points evaluated in one batch."""
    x = np.asarray(x, dtype=float)
    d = x.size
    h = step * np.where(x != 0, np.abs(x), 1.0)
    P = np.repeat(x[None], 2 * d, axis=0)
    P[np.arange(d), np.arange(d)] += h
    P[d + np.arange(d), np.arange(d)] -= h
    R = problem.fisher_residuals(P)
    return ((R[:d] - R[d:]) / (2 * h[:, None])).T


def entry_sigma(sigma: np.ndarray, groups: np.ndarray) -> np.ndarray | None:
    """The noise's sigma of each residual entry, from ``sigma`` per group or per entry;
    ``None`` for another shape, a negative or non-finite value, or no noise at all."""
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


def informative(sigma: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """The entries that carry information, ``(m,)`` bool: ``σ_k`` above :data:`ROUNDING`
    times the largest ``σ`` of its group (the others are noise-free or rounding noise)."""
    top = np.zeros(int(groups.max()) + 1)
    np.maximum.at(top, groups, sigma)
    return sigma > ROUNDING * top[groups]


def floored(sigma: np.ndarray, groups: np.ndarray, fraction: float) -> np.ndarray:
    """``σ_k`` floored at ``fraction`` times the rms ``σ`` of its group."""
    ngroups = int(groups.max()) + 1
    rms = np.sqrt(np.bincount(groups, sigma**2, ngroups) / np.bincount(groups, None, ngroups))
    return np.maximum(sigma, fraction * rms[groups])


def _bounds(J: np.ndarray, sigma: np.ndarray, x_true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounds (percent) and the whitened Jacobian of the rows of ``J`` with ``σ``."""
    Jw = J / sigma[:, None]
    fisher = Jw.T @ Jw
    try:
        cov = np.linalg.inv(fisher)
    except np.linalg.LinAlgError:
        cov = np.linalg.pinv(fisher)
    return 100.0 * np.sqrt(np.maximum(np.diag(cov), 0.0)) / np.abs(x_true), Jw


def cramer_rao(problem: Problem) -> dict[str, Any] | None:
    """Bounds at the truth (see the module), or ``None`` without a truth, residuals or a
    noise level: ``crb_percent`` per parameter, its norm, the scaled Jacobian's
    ``singular_values`` and ``condition_number``, ``sigma`` per group (rms when given per
    entry), ``excluded_entries`` and, where ``σ`` varies within a group,
    ``sigma_floor_sensitivity`` (one entry per :data:`FLOOR_FRACTIONS`)."""
    x_true, sigma = problem.x_true, problem.residual_sigma()
    if x_true is None or sigma is None:
        return None
    groups = np.asarray(problem.fisher_groups(), dtype=int)
    per_entry = entry_sigma(np.asarray(sigma, dtype=float), groups)
    if per_entry is None:
        return None
    J = jacobian(problem, x_true)
    kept = informative(per_entry, groups)
    crb, Jw = _bounds(J[kept], per_entry[kept], x_true)
    s = np.linalg.svd(Jw * x_true[None], compute_uv=False)
    given, ngroups = np.asarray(sigma, dtype=float).reshape(-1), int(groups.max()) + 1
    out: dict[str, Any] = {
        "names": list(problem.bounds.names),
        "crb_percent": crb.tolist(),
        "crb_norm_percent": float(np.linalg.norm(crb)),
        "singular_values": s.tolist(),
        "condition_number": float(s[0] / s[-1]) if s[-1] > 0 else float("inf"),
        "sigma": given.tolist() if given.size == ngroups else  # per entry: each group's rms
        [float(np.sqrt(np.mean(per_entry[groups == g] ** 2))) for g in range(ngroups)],
        "excluded_entries": int(np.sum(~kept)),
    }
    varies = any(np.ptp(per_entry[kept & (groups == g)]) > 0 for g in np.unique(groups[kept]))
    if varies:
        out["sigma_floor_sensitivity"] = []
        for fraction in FLOOR_FRACTIONS:
            b = _bounds(J[kept], floored(per_entry, groups, fraction)[kept], x_true)[0]
            out["sigma_floor_sensitivity"].append({
                "fraction": fraction, "crb_percent": b.tolist(),
                "crb_norm_percent": float(np.linalg.norm(b))})
    return out


def per_instance(problem: Problem, runs: int) -> list[dict[str, Any]]:
    """The bounds of each instance runs ``0 .. runs-1`` fit (runs of one instance share an
    entry): ``instance`` (id), ``runs``, ``crb_percent``, ``crb_norm_percent`` and, where
    ``σ`` varies along a channel, ``sigma_floor_norms``; an instance without one is left out."""
    out: list[dict[str, Any]] = []
    by_id: dict[str | None, dict[str, Any]] = {}
    for i in range(runs):
        inst = kept_instance(problem, i)
        key = inst.instance_id()
        if key in by_id:
            by_id[key]["runs"].append(i)
            continue
        crb = cramer_rao(inst)
        if crb is None:
            continue
        entry: dict[str, Any] = {"instance": key, "runs": [i],
                                 "crb_percent": crb["crb_percent"],
                                 "crb_norm_percent": crb["crb_norm_percent"]}
        if "sigma_floor_sensitivity" in crb:
            entry["sigma_floor_norms"] = [s["crb_norm_percent"]
                                          for s in crb["sigma_floor_sensitivity"]]
        by_id[key] = entry
        out.append(entry)
    return out
