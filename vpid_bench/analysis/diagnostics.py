"""Fit diagnostics: does the fitted model explain the record? (as MATLAB's ``resid`` and
``compare`` give them; what and why: docs/estimators.md and docs/report.md, fit diagnostics).

Per residual group: ``rms`` beside the signal's and the noise ``sigma`` (stated, or
``σ̂² = mean((Δ²r)²) / 6``), ``acf`` with its 99 % band ``± 2.576 / sqrt(n)`` and Ljung–Box,
``cross`` per input with Bartlett's band; flags ``correlated`` (Ljung–Box p below
:data:`ALPHA`), ``input_correlated`` (over :data:`CROSS_SHARE` of lags outside) and ``misfit``
(``rms_over_sigma`` above :data:`MISFIT`). ``explained`` is false when any group is
``correlated`` or ``input_correlated``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..store.job_checks import DIAGNOSTICS_SCHEMA as SCHEMA
from ..store.job_files import DIAGNOSTICS, write_job_json
from .intervals import jacobian_intervals

#: The two-sided 99 % normal quantile (scipy.stats.norm.ppf(0.995)).
Z99 = 2.5758293035489004
#: Significance level of the whiteness test (Ljung–Box).
ALPHA = 0.01
#: Most autocorrelation and cross-correlation lags kept (MATLAB's ``resid`` shows 25).
MAX_LAGS = 25
#: Most lags of the Ljung–Box test (fewer for short records: a quarter of the samples).
LJUNG_BOX_LAGS = 20
#: A share of cross-correlation lags outside the 99 % band above this flags an input.
CROSS_SHARE = 0.1
#: Residual rms above this many noise sigmas: the model leaves a misfit beyond the noise.
MISFIT = 1.5
#: Fewest entries of a group that are diagnosed (fewer give no useful correlation).
MIN_SAMPLES = 8


def acf(r: np.ndarray, lags: int) -> np.ndarray:
    """The sample autocorrelation of ``r`` at lags ``0..lags`` (biased estimator, the one
    every whiteness test uses: ``Σ r_t r_{t+k} / Σ r_t²`` about the mean)."""
    r = np.asarray(r, dtype=float) - np.mean(r)
    den = float(r @ r)
    if den == 0.0:
        return np.r_[1.0, np.zeros(lags)]
    return np.array([1.0] + [float(r[:-k] @ r[k:]) / den for k in range(1, lags + 1)])


def ccf(r: np.ndarray, u: np.ndarray, lags: int) -> np.ndarray:
    """``corr(r_t, u_{t-k})`` at ``k = -lags..lags`` (biased, about the means); zeros where
    either series is constant."""
    r = np.asarray(r, dtype=float) - np.mean(r)
    u = np.asarray(u, dtype=float) - np.mean(u)
    den = math.sqrt(float(r @ r) * float(u @ u))
    out = np.zeros(2 * lags + 1)
    if den == 0.0:
        return out
    for i, k in enumerate(range(-lags, lags + 1)):
        out[i] = (float(r[k:] @ u[:u.size - k]) if k >= 0 else float(r[:k] @ u[-k:])) / den
    return out


def ljung_box(r: np.ndarray, lags: int) -> tuple[float, float]:
    """The Ljung–Box statistic over lags ``1..lags`` and its p-value (χ² with ``lags``
    degrees of freedom; statsmodels' ``acorr_ljungbox`` gives the same, tested). The χ²
    survival function from ``scipy.special`` (``chdtrc``, what ``scipy.stats.chi2.sf``
    computes): importing ``scipy.stats`` cost each job's analysis 0.65 s."""
    from scipy.special import chdtrc

    n = r.size
    rho = acf(r, lags)[1:]
    q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, lags + 1))))
    return q, float(chdtrc(lags, q))


def second_difference_sigma(r: np.ndarray) -> float:
    """The white-noise sigma of ``r`` from its second differences, ``sqrt(mean(Δ²r²) / 6)``
    (``var(e_t - 2e_{t-1} + e_{t-2}) = 6σ²`` for white ``e``)."""
    d2 = np.diff(np.asarray(r, dtype=float), n=2)
    return float(math.sqrt(float(d2 @ d2) / (6 * d2.size))) if d2.size else math.nan


def _rms(v: np.ndarray) -> float:
    return float(math.sqrt(float(v @ v) / v.size)) if v.size else math.nan


def _num(v: float) -> float | None:
    """JSON-able: ``None`` for a value that is not finite."""
    return float(v) if math.isfinite(v) else None


def group_diagnostics(r: np.ndarray, measured: np.ndarray | None = None,
                      sigma: float | None = None,
                      inputs: Mapping[str, np.ndarray] | None = None,
                      lags: int = MAX_LAGS) -> dict[str, Any]:
    """The diagnostics of one group's residuals ``r`` in time order (see the module)."""
    r = np.asarray(r, dtype=float).reshape(-1)
    n = r.size
    lags = max(1, min(lags, n // 4))
    rms = _rms(r)
    stated = sigma is not None and math.isfinite(sigma) and sigma > 0
    s = float(sigma) if stated else second_difference_sigma(r)
    signal = _rms(np.asarray(measured, dtype=float).reshape(-1)) if measured is not None \
        else math.nan
    rho = acf(r, lags)
    h = max(1, min(LJUNG_BOX_LAGS, n // 4))
    q, p = ljung_box(r, h)
    band = Z99 / math.sqrt(n)
    cross = {}
    for name, u in (inputs or {}).items():
        u = np.asarray(u, dtype=float).reshape(-1)
        if u.size == n and np.all(np.isfinite(u)):  # with its Bartlett 99 % band
            var = (1.0 + 2.0 * float(rho[1:] @ acf(u, lags)[1:])) / n
            u_band = Z99 * math.sqrt(max(var, 1.0 / n))
            c = ccf(r, u, lags)
            at = int(np.argmax(np.abs(c)))
            cross[str(name)] = {"ccf": c.tolist(), "band99": u_band, "max_abs": float(abs(c[at])),
                                "lag_at_max": at - lags,
                                "outside": float(np.mean(np.abs(c) > u_band))}
    over = rms / s if s > 0 else math.nan
    return {
        "n": n, "rms": _num(rms), "signal_rms": _num(signal),
        "rms_over_signal": _num(rms / signal) if signal > 0 else None,
        "sigma": _num(s), "sigma_source": "stated" if stated else "estimated",
        "rms_over_sigma": _num(over),
        "lags": lags, "acf": rho.tolist(), "band99": band, "lag1": float(rho[1]),
        "acf_outside": float(np.mean(np.abs(rho[1:]) > band)),
        "ljung_box_lags": h, "ljung_box_q": _num(q), "ljung_box_p": _num(p),
        "cross": cross,
        "correlated": bool(p < ALPHA),
        "input_correlated": any(c["outside"] > CROSS_SHARE for c in cross.values()),
        "misfit": bool(math.isfinite(over) and over > MISFIT),
    }


def fit_diagnostics(residuals: np.ndarray, groups: np.ndarray,
                    measured: np.ndarray | None = None,
                    sigma: np.ndarray | Sequence[float] | None = None,
                    inputs: Mapping[str, np.ndarray] | None = None,
                    names: Sequence[str] | None = None,
                    held_out: Mapping[str, float] | None = None,
                    lags: int = MAX_LAGS) -> dict[str, Any]:
    """The fit diagnostics of residuals at an identified vector (see the module).

    ``residuals`` and ``groups`` ``(m,)`` (a group's entries in time order); ``measured``
    ``(m,)`` in the residuals' units; ``sigma`` per group (``None`` or non-positive:
    estimated); ``inputs`` ``{name: (T,)}`` sampled as a group of ``T`` entries; ``names``:
    each group's channel; ``held_out``: ``{"error": e, "naive": e0}`` (same units). A group
    of fewer than :data:`MIN_SAMPLES` entries or a non-finite residual is left out;
    :class:`ValueError` when the shapes differ."""
    r = np.asarray(residuals, dtype=float).reshape(-1)
    g = np.asarray(groups, dtype=int).reshape(-1)
    if r.shape != g.shape:
        raise ValueError(f"residuals {r.shape} and groups {g.shape} differ in shape")
    y = None if measured is None else np.asarray(measured, dtype=float).reshape(-1)
    if y is not None and y.shape != r.shape:
        raise ValueError(f"measured {y.shape} and residuals {r.shape} differ in shape")
    sig = None if sigma is None else np.asarray(sigma, dtype=float).reshape(-1)
    out = []
    for k in (np.unique(g) if g.size else []):
        mine = g == k
        rk = r[mine]
        if rk.size < MIN_SAMPLES or not np.all(np.isfinite(rk)):
            continue
        sk = float(sig[k]) if sig is not None and k < sig.size else None
        entry = {"group": int(k),
                 "name": str(names[k]) if names is not None and k < len(names) else str(k)}
        entry.update(group_diagnostics(rk, None if y is None else y[mine], sk, inputs, lags))
        out.append(entry)
    held = None
    if held_out and all(isinstance(held_out.get(key), (int, float))
                        and math.isfinite(held_out[key]) for key in ("error", "naive")):
        e, e0 = float(held_out["error"]), float(held_out["naive"])
        held = {"error": e, "naive": e0, "ratio": _num(e / e0) if e0 > 0 else None,
                "unit": str(held_out.get("unit", ""))[:16]}
    return {"schema": SCHEMA, "groups": out, "held_out": held,
            "explained": not any(e["correlated"] or e["input_correlated"] for e in out)}


def problem_diagnostics(problem: Any, x: Any) -> dict[str, Any]:
    """The fit diagnostics of ``problem`` (one with residuals) at ``x``: its
    ``fisher_residuals`` by ``fisher_groups``, its stated ``residual_sigma`` per group and
    its optional ``diagnostic_signals(x)`` (a dict of :func:`fit_diagnostics`' ``measured``,
    ``names``, ``inputs``, ``held_out``); with ``x``, ``f`` and both ``intervals``
    (:func:`.intervals.jacobian_intervals`)."""
    x = np.asarray(x, dtype=float).reshape(-1)
    groups = np.asarray(problem.fisher_groups(), dtype=int).reshape(-1)
    r = np.asarray(problem.fisher_residuals(x[None]), dtype=float)[0]
    sigma = problem.residual_sigma()
    sigma = None if sigma is None else np.asarray(sigma, dtype=float).reshape(-1)
    if sigma is not None and groups.size and sigma.size != int(groups.max()) + 1:
        sigma = None  # given per entry: estimated per group instead
    given = getattr(problem, "diagnostic_signals", None)
    extra = (given(x) if callable(given) else None) or {}
    out = fit_diagnostics(r, groups, measured=extra.get("measured"), sigma=sigma,
                          inputs=extra.get("inputs"), names=extra.get("names"),
                          held_out=extra.get("held_out"))
    out.update(x=x.tolist(), names=list(problem.bounds.names),
               f=float(np.asarray(problem.evaluate(x[None]), dtype=float)[0]),
               instance=problem.instance_id(), intervals=jacobian_intervals(problem, x))
    return out


def write_diagnostics(problem: Any, x: Any, job_dir: Any) -> Any:
    """``job_dir/diagnostics.json`` at ``x``, or with ``status`` ``failed`` and why."""
    try:
        data = {"status": "ok", **problem_diagnostics(problem, x)}
    except (ValueError, FloatingPointError, np.linalg.LinAlgError, TypeError) as exc:
        data = {"schema": SCHEMA, "status": "failed",
                "reason": " ".join(f"{type(exc).__name__}: {exc}".split())[:200]}
    return write_job_json(Path(job_dir) / DIAGNOSTICS, data)
