"""Which model structure does a record support? Candidate structures fitted to one record and
compared as system identification does (issue 43; MATLAB's ``compare``, ``aic``, ``resid``),
through ``fisher_residuals``, ``fisher_groups`` and ``bounds`` only: each fitted on its
channels' first :data:`FIT_FRACTION` and judged on the rest (:data:`METHOD` says how;
docs/own-record.md). AIC, BIC: ``-2 log L = sum_c n_c log(RSS_c / n_c)`` plus ``2 k`` or
``k log n``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .diagnostics import ljung_box

#: Lags of the whiteness test (samples).
LAGS = 20
#: Of each channel's samples, the share fitted; the rest is held out.
FIT_FRACTION = 2 / 3


@dataclasses.dataclass(frozen=True)
class StructureFit:
    """One structure fitted to the record (see the module for each quantity)."""

    label: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    x: np.ndarray
    lower: np.ndarray  # 95 % interval
    upper: np.ndarray
    k: int
    heldout: float
    aic: float
    bic: float
    white_p: float  # the Bonferroni-adjusted smallest Ljung-Box p-value (capped at 1)
    fit_error: float  # Eq. 3 on the fit segment


def ljung_box_p(residuals: np.ndarray, lags: int = LAGS) -> float:
    """The Ljung-Box p-value of one residual series at ``lags``
    (:func:`.diagnostics.ljung_box`, statsmodels' value, tested)."""
    return ljung_box(np.asarray(residuals, dtype=float), lags)[1]


def segments(groups: np.ndarray, fit_fraction: float = FIT_FRACTION
             ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per channel (group), the indices of its fit samples and of its validation samples."""
    fit, val = [], []
    for g in np.unique(groups):
        idx = np.flatnonzero(groups == g)
        cut = int(round(fit_fraction * idx.size))
        fit.append(idx[:cut])
        val.append(idx[cut:])
    return fit, val


def information_criteria(rss: Sequence[float], n: Sequence[int], k: int) -> tuple[float, float]:
    """``(AIC, BIC)`` with each channel's variance profiled out (see the module)."""
    m2logl = float(sum(nc * math.log(max(r, 1e-300) / nc) for r, nc in zip(rss, n, strict=True)))
    total = int(sum(n))
    return m2logl + 2 * k, m2logl + k * math.log(total)


def fit_structure(problem: Any, label: str, x0: np.ndarray | None = None,
                  fit_fraction: float = FIT_FRACTION, z: float = 1.96,
                  max_nfev: int = 400) -> StructureFit:
    """Fit ``problem`` on its fit segment from ``x0`` (default: the box centre) and measure
    the structure (the module)."""
    from scipy.optimize import least_squares

    b = problem.bounds
    lo, hi = np.asarray(b.lower, dtype=float), np.asarray(b.upper, dtype=float)
    width = hi - lo
    fit_idx, val_idx = segments(np.asarray(problem.fisher_groups()), fit_fraction)
    every_fit = np.concatenate(fit_idx)
    x0 = 0.5 * (lo + hi) if x0 is None else np.clip(np.asarray(x0, dtype=float), lo, hi)

    def residuals(zz: np.ndarray) -> np.ndarray:
        r = problem.fisher_residuals((lo + zz * width)[None])[0]
        return np.where(np.isfinite(r), r, 1e3)[every_fit]

    sol = least_squares(residuals, (x0 - lo) / width, bounds=(0.0, 1.0), method="trf",
                        x_scale=1.0, max_nfev=max_nfev, diff_step=1e-6)
    x = lo + sol.x * width
    r_all = problem.fisher_residuals(x[None])[0]
    rss = [float(np.sum(r_all[i] ** 2)) for i in fit_idx]
    n = [int(i.size) for i in fit_idx]
    aic, bic = information_criteria(rss, n, x.size)
    p_min = min(ljung_box_p(r_all[i]) for i in fit_idx)
    # z standard errors per parameter from the Jacobian whitened by each channel's fitted
    # sigma; a parameter on its bound (within 1e-6 of it) is held there and gets NaN, the
    # others' covariance is that of the free columns
    sigma = np.concatenate([np.full(nc, math.sqrt(r / nc)) for r, nc in zip(rss, n, strict=True)])
    half = np.full(x.size, np.nan)
    free = (sol.x > 1e-6) & (sol.x < 1 - 1e-6)
    if np.any(free):
        Jf = (sol.jac / sigma[:, None] / width[None, :])[:, free]
        try:
            half[free] = z * np.sqrt(np.clip(np.diag(np.linalg.inv(Jf.T @ Jf)), 0.0, None))
        except np.linalg.LinAlgError:
            half[free] = np.inf
    return StructureFit(
        label=label, names=tuple(b.names), units=tuple(b.units or ("",) * x.size), x=x,
        lower=x - half, upper=x + half, k=int(x.size),
        heldout=float(sum(np.linalg.norm(r_all[i]) for i in val_idx)),
        aic=aic, bic=bic, white_p=min(1.0, p_min * len(fit_idx)),
        fit_error=float(sum(math.sqrt(r) for r in rss)))


def ranked(fits: Sequence[StructureFit]) -> list[StructureFit]:
    """The fits best first: by held-out error, then BIC."""
    return sorted(fits, key=lambda f: (f.heldout, f.bic))


def verdict(fits: Sequence[StructureFit], alpha: float = 0.05) -> str:
    """Which structure the record supports and by how much, in one paragraph."""
    order = ranked(fits)
    best = order[0]
    by_bic = min(fits, key=lambda f: f.bic)
    white = [f.label for f in fits if f.white_p >= alpha]
    text = [f"The record supports **{best.label}**: the lowest held-out error "
            f"({best.heldout:.4g}"]
    if len(order) > 1:
        nxt = order[1]
        text[-1] += (f", {100 * (1 - best.heldout / nxt.heldout):.3g} % below the next, "
                     f"{nxt.label}, at {nxt.heldout:.4g}")
    text[-1] += ")"
    if by_bic is best:
        others = [f.bic - best.bic for f in fits if f is not best]
        if others:
            text.append(f"and the lowest BIC ({min(others):.4g} below the next; above 10 "
                        "is very strong evidence)")
    else:
        text.append(f"but BIC prefers {by_bic.label} by {best.bic - by_bic.bic:.4g}")
    if best.label in white:
        text.append(f"its residuals pass the whiteness test (Ljung-Box, {LAGS} lags, "
                    f"p = {best.white_p:.3g} >= {alpha:g})")
    else:
        text.append(f"yet its residuals fail the whiteness test (p = {best.white_p:.3g} < "
                    f"{alpha:g}): some of the record's dynamics are in no candidate")
    failing = [f.label for f in fits if f.white_p < alpha and f is not best]
    if failing:
        text.append("residuals not white: " + ", ".join(failing))
    return "; ".join(text) + "."


#: How the comparison is made, in one paragraph (the report section's opening).
METHOD = ("Each structure refitted (least squares) on each channel's first "
          f"{FIT_FRACTION:.3g} of samples from its best run, and judged on the rest: held-out "
          "error (sum over channels of the misfit's norm on the samples no fit saw, each over "
          "the channel's norm on the record), ΔAIC and ΔBIC from the best (each channel's "
          f"variance profiled out), the Ljung-Box whiteness p-value ({LAGS} lags, Bonferroni "
          "over channels; white when at least the report's alpha), the identified values with "
          "95 % Gauss-Newton intervals (none, nan, for a parameter left on a bound of the box).")


@dataclasses.dataclass(frozen=True)
class StructureSummary:
    """What a report shows of one record's structures: the method, the verdict, the ranking
    table and the values table (headers and rows each)."""

    method: str
    verdict: str
    table: tuple[list[str], list[list[Any]]]
    values: tuple[list[str], list[list[Any]]]


def structure_summary(fits: Sequence[StructureFit], alpha: float = 0.05) -> StructureSummary:
    """The :class:`StructureSummary` of fitted structures of one record: one table row per
    structure and one value row per structure and parameter, best first."""
    order = ranked(fits)
    a0, b0 = min(f.aic for f in fits), min(f.bic for f in fits)
    table = [[f.label, f.k, f.heldout, f.fit_error, f.aic - a0, f.bic - b0, f.white_p]
             for f in order]
    values = [[f.label, *row] for f in order
              for row in zip(f.names, f.units, f.x, f.lower, f.upper, strict=True)]
    return StructureSummary(
        METHOD, verdict(fits, alpha),
        (["structure", "k", "held-out error", "fit error", "ΔAIC", "ΔBIC", "whiteness p"], table),
        (["structure", "parameter", "unit", "value", "95 % low", "95 % high"], values))
