"""The report's summary table from the tidy run rows, numpy only (the single job's report
shares it): per context and algorithm the statistics of the headline metric, the objective
and every metric, and the rank (:func:`summarize`); and how each fares against the baseline
(:func:`baseline_verdicts`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .load import Rows, by_context, grouped
from .render import p_text

#: The optimizer every report compares against by default (random search).
BASELINE = "random"


def metric_stats(m: Sequence[float], f: Sequence[float]) -> dict[str, float]:
    """Statistics of the per-run metric ``m`` and objective ``f`` of the successful runs
    (empty for none); infinite values count (a run that found nothing finite is the worst)."""
    m, f = np.asarray(m, dtype=float), np.asarray(f, dtype=float)
    if not len(m):
        return {}
    with np.errstate(invalid="ignore", over="ignore"):
        q1, q3 = np.percentile(m, [25, 75])
        return {
            "median": float(np.median(m)), "q1": float(q1), "q3": float(q3),
            "iqr": float(q3 - q1) if np.isfinite(q3 - q1) else math.inf,
            "mean": float(np.mean(m)),
            "sd": float(np.std(m, ddof=1)) if len(m) > 1 else math.nan,
            "best": float(np.min(m)), "worst": float(np.max(m)),
            "f_median": float(np.median(f)), "f_mean": float(np.mean(f)),
            "f_sd": float(np.std(f, ddof=1)) if len(f) > 1 else math.nan,
            "f_best": float(np.min(f)), "f_worst": float(np.max(f))}


def summarize(rows: Rows) -> list[dict[str, Any]]:
    """One row per context and algorithm, sorted by context then rank (1 = lowest median
    metric, then mean; NaN without a successful run), with the :func:`metric_stats` keys."""
    groups = grouped(rows, lambda r: (r["context"], r["algorithm"]))
    names = list(dict.fromkeys(k[7:] for r in rows for k in r if k.startswith("metric.")))
    out = []
    for (context, algorithm), g in sorted(groups.items()):
        ok = [r for r in g if r["status"] == "ok"]
        first = g[0]
        row: dict[str, Any] = {
            "context": context, "problem": first["problem"], "ps": first["ps"],
            "algorithm": algorithm, "optimizer": first["optimizer"],
            "metric_name": first["metric_name"], "n_runs": len(ok), "n_failed": len(g) - len(ok)}
        row.update(metric_stats([r["metric"] for r in ok], [r["f_best"] for r in ok]))
        for name in names:
            vals = [r.get(f"metric.{name}", math.nan) for r in ok]
            vals = [v for v in vals if not math.isnan(v)]
            row[f"{name}_median"] = float(np.median(vals)) if vals else math.nan
        if ok:
            ev = np.asarray([r["evaluations"] for r in ok], dtype=float)
            wall_ok = np.asarray([r["wall_time_s"] for r in ok], dtype=float)
            wall = np.asarray([r["wall_time_s"] for r in g], dtype=float)
            row.update(evaluations_median=float(np.median(ev)), evaluations_max=float(ev.max()),
                       budget=first["budget"],
                       wall_time_mean_s=float(np.mean(wall_ok[np.isfinite(wall_ok)]))
                       if np.isfinite(wall_ok).any() else math.nan,
                       wall_time_total_s=float(np.sum(wall[np.isfinite(wall)])))
        out.append(row)
    # per context, those with runs by median, then mean (NaN last), then the rest
    out.sort(key=lambda r: (r["context"], 0, r["median"], math.inf if math.isnan(r["mean"])
                            else r["mean"], r["algorithm"]) if r["n_runs"] else (r["context"], 1))
    for g in by_context(out).values():
        for i, r in enumerate(g, start=1):
            r["rank"] = i if r["n_runs"] else math.nan
    return out


def baseline_verdicts(summary: Rows, pairs: Any, baseline: str = BASELINE) -> list[str]:
    """Per summary row, against its context's baseline: ``baseline``, ``beats it (...)``,
    ``does not clear it (...)``, ``WORSE than it (...)``, ``not tested`` or ``""`` (not
    run). ``pairs``: the pairwise tests, or ``None``."""
    def verdict(r: Mapping[str, Any]) -> str:
        bases = [b for b in summary if b["context"] == r["context"]
                 and b["optimizer"] == baseline]
        if not bases or r["optimizer"] == baseline:
            return "baseline" if bases else ""
        base = bases[0]["algorithm"]
        if pairs is None or pairs.empty:
            return "not tested"
        sel = pairs[(pairs["context"] == r["context"])
                    & (((pairs["a"] == r["algorithm"]) & (pairs["b"] == base))
                       | ((pairs["a"] == base) & (pairs["b"] == r["algorithm"])))]
        if sel.empty or not np.isfinite(sel["p_holm"].iloc[0]):
            return "not tested"
        detail = pair_detail(sel.iloc[0], r["algorithm"])
        if sel["better"].iloc[0] == r["algorithm"]:
            return f"beats it ({detail})"
        if sel["better"].iloc[0] == base:
            return f"WORSE than it ({detail})"
        return f"does not clear it ({detail})"

    return [verdict(r) for r in summary]


def pair_detail(pair: Mapping[str, Any], first: str) -> str:
    """``p_holm=8.4e-08, A12=0.05 [0.01, 0.12]`` for one pairwise test, A12 seen from
    ``first`` (``p_holm≤...`` where the value is a bound)."""
    p = float(pair["p_holm"])
    text = p_text(p, bool(pair.get("p_at_floor", False)), "p_holm")
    a, lo, hi = (float(pair.get(k, np.nan)) for k in ("A12", "A12_lo", "A12_hi"))
    if pair["a"] != first:  # the row holds A12(a, b); seen from b it is 1 - A12
        a, lo, hi = 1 - a, 1 - hi, 1 - lo
    if np.isfinite(a):
        text += f", A12={a:.2f}"
        if np.isfinite(lo) and np.isfinite(hi):
            text += f" [{lo:.2f}, {hi:.2f}]"
    return text
