"""The report's tables, computed from the tidy runs table (see :mod:`.load`).

* :func:`mean_vector_table`: the paper's Tables II/III: per context and algorithm, the mean of
  the identified vectors over the successful runs, each parameter's relative error of that
  mean (percent) and its NoRE, beside the published values and the difference.
* :func:`run_stats_table`: what the paper lacks: per-run metric median, IQR, mean ± sd, best,
  worst, objective statistics, evaluations, wall time, and two rankings (median per-run
  metric; the paper's mean-vector NoRE).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..api import nore as nore_of
from ..api import relative_errors_percent
from . import paper

BASELINE = "random"


def param_names(df: Any) -> list[str]:
    """Parameter names present in the table (columns ``x.<name>``), in column order."""
    return [c[2:] for c in df.columns if c.startswith("x.")]


def _params_of(g: Any) -> list[str]:
    return [p for p in param_names(g) if g[f"x.{p}"].notna().any()]


def _paper_name_map(problem: str, names: list[str]) -> dict[str, str] | None:
    """Our parameter name -> the paper's, or None when the paper does not apply."""
    if problem != paper.PAPER_PROBLEM:
        return None
    if set(names) >= set(paper.PARAMETERS):
        return {p: p for p in paper.PARAMETERS}
    if len(names) == len(paper.PARAMETERS):  # same order as Eq. 4, other spellings
        return dict(zip(names, paper.PARAMETERS, strict=True))
    return None


def mean_vector_summary(x: np.ndarray, true: np.ndarray, names: list[str], *, problem: str,
                        optimizer: str, algorithm: str, ps: Any) -> dict[str, Any] | None:
    """The mean of the finite rows of ``x`` (runs x parameters), its relative errors (%) and
    NoRE against ``true``, and the paper's row in ``names`` order where the paper has one
    (``paper``: table, note, mean, eps, nore; else ``None``). ``None`` when no row is finite.
    No pandas: the single job's report uses this too."""
    x = np.asarray(x, dtype=float)
    x = x[np.all(np.isfinite(x), axis=1)]
    if not len(x):
        return None
    true = np.asarray(true, dtype=float)
    mean = x.mean(axis=0)
    out: dict[str, Any] = {"n_runs": len(x), "mean": mean,
                           "eps": relative_errors_percent(mean, true),
                           "nore": nore_of(mean, true), "paper": None}
    mapping = _paper_name_map(problem, names)
    if mapping is None or algorithm != optimizer or ps is None:
        return out
    pub = paper.published(None, optimizer, int(ps))
    if pub is not None:
        out["paper"] = {
            "table": pub["table"], "note": pub["note"], "nore": pub["nore"],
            "mean": np.array([pub["mean"][mapping[p]] for p in names]),
            "eps": np.array([pub["eps"][mapping[p]] for p in names]),
        }
    return out


def mean_vector_table(df: Any) -> Any:
    """Long table: context, problem, ps, algorithm, n_runs, source (ours | paper |
    difference), quantity (mean | eps_percent), one column per parameter, nore, note.

    Only contexts whose runs know the true parameters appear. ``difference`` is ours minus
    the paper's (for ε and NoRE, in percentage points)."""
    import pandas as pd

    ok = df[df["status"] == "ok"]
    rows: list[dict[str, Any]] = []
    for (context, algorithm), g in ok.groupby(["context", "algorithm"], sort=True):
        names = _params_of(g)
        true_cols = [f"true.{p}" for p in names]
        if not names or not all(c in g for c in true_cols) or g[true_cols].isna().any().any():
            continue
        mv = mean_vector_summary(
            g[[f"x.{p}" for p in names]].to_numpy(float), g[true_cols].iloc[0].to_numpy(float),
            names, problem=g["problem"].iloc[0], optimizer=g["optimizer"].iloc[0],
            algorithm=algorithm, ps=g["ps"].iloc[0])
        if mv is None:
            continue
        mean, eps = mv["mean"], mv["eps"]
        base = {"context": context, "problem": g["problem"].iloc[0], "ps": g["ps"].iloc[0],
                "algorithm": algorithm, "n_runs": mv["n_runs"]}
        rows.append({**base, "source": "ours", "quantity": "mean", **dict(zip(names, mean)),
                     "nore": np.nan, "note": ""})
        rows.append({**base, "source": "ours", "quantity": "eps_percent",
                     **dict(zip(names, eps)), "nore": mv["nore"], "note": ""})
        pub = mv["paper"]
        if pub is None:
            continue
        note = f"Table {pub['table']}" + (f"; {pub['note']}" if pub["note"] else "")
        rows.append({**base, "source": "paper", "quantity": "mean",
                     **dict(zip(names, pub["mean"])), "nore": np.nan, "note": note})
        rows.append({**base, "source": "paper", "quantity": "eps_percent",
                     **dict(zip(names, pub["eps"])), "nore": pub["nore"], "note": note})
        rows.append({**base, "source": "difference", "quantity": "mean",
                     **dict(zip(names, mean - pub["mean"])), "nore": np.nan,
                     "note": "ours - paper"})
        rows.append({**base, "source": "difference", "quantity": "eps_percent",
                     **dict(zip(names, eps - pub["eps"])), "nore": mv["nore"] - pub["nore"],
                     "note": "ours - paper"})
    return pd.DataFrame(rows)


def metric_stats(m: np.ndarray, f: np.ndarray) -> dict[str, float]:
    """Statistics of the per-run metric ``m`` and objective ``f`` of the successful runs:
    median, q1, q3, iqr, mean, sd (sample; NaN for one run), best, worst; f_median, f_mean,
    f_sd, f_best, f_worst. Empty for no run. No pandas."""
    m, f = np.asarray(m, dtype=float), np.asarray(f, dtype=float)
    if not len(m):
        return {}
    with np.errstate(invalid="ignore"):
        q1, q3 = np.nan_to_num(np.percentile(m, [25, 75]), nan=np.inf)
        return {
            "median": float(np.median(m)), "q1": float(q1), "q3": float(q3),
            "iqr": float(q3 - q1), "mean": float(np.mean(m)),
            "sd": float(np.std(m, ddof=1)) if len(m) > 1 else np.nan,
            "best": float(np.min(m)), "worst": float(np.max(m)),
            "f_median": float(np.median(f)), "f_mean": float(np.mean(f)),
            "f_sd": float(np.std(f, ddof=1)) if len(f) > 1 else np.nan,
            "f_best": float(np.min(f)), "f_worst": float(np.max(f)),
        }


def run_stats_table(df: Any, meanvec: Any | None = None) -> Any:
    """Per context and algorithm: per-run metric statistics, objective statistics,
    evaluations, wall time and the two rankings (1 = best within the context)."""
    import pandas as pd

    rows = []
    for (context, algorithm), g in df.groupby(["context", "algorithm"], sort=True):
        ok = g[g["status"] == "ok"]
        m = ok["metric"].to_numpy(float)
        f = ok["f_best"].to_numpy(float)
        row = {
            "context": context, "problem": g["problem"].iloc[0], "ps": g["ps"].iloc[0],
            "algorithm": algorithm, "optimizer": g["optimizer"].iloc[0],
            "metric_name": g["metric_name"].iloc[0],
            "n_runs": len(ok), "n_failed": int((g["status"] != "ok").sum()),
        }
        if len(m):
            row.update(metric_stats(m, f))
            row.update(evaluations_median=float(ok["evaluations"].median()),
                       evaluations_max=float(ok["evaluations"].max()),
                       budget=g["budget"].iloc[0],
                       wall_time_mean_s=float(ok["wall_time_s"].mean()),
                       wall_time_total_s=float(g["wall_time_s"].sum()))
        rows.append(row)
    table = pd.DataFrame(rows)
    if table.empty:
        return table
    for col in ("median", "mean"):
        if col not in table:
            table[col] = np.nan
    # Ranking by median per-run metric (ties broken by the mean).
    table["rank_median"] = (
        table.sort_values(["context", "median", "mean"])
        .groupby("context").cumcount() + 1
    ).reindex(table.index)
    table.loc[table["median"].isna(), "rank_median"] = np.nan
    table["meanvec_nore"] = np.nan
    table["paper_nore"] = np.nan
    if meanvec is not None and not meanvec.empty:
        eps = meanvec[meanvec["quantity"] == "eps_percent"]
        for src, col in (("ours", "meanvec_nore"), ("paper", "paper_nore")):
            s = eps[eps["source"] == src].set_index(["context", "algorithm"])["nore"]
            table[col] = [s.get((c, a), np.nan) for c, a in
                          zip(table["context"], table["algorithm"], strict=True)]
    table["rank_meanvec_nore"] = table.groupby("context")["meanvec_nore"].rank(method="min")
    table["rank_paper_nore"] = table.groupby("context")["paper_nore"].rank(method="min")
    return table.sort_values(["context", "rank_median"], ignore_index=True)


def baseline_verdicts(stats_table: Any, pairs: Any, baseline: str = BASELINE) -> list[str]:
    """Per row of ``stats_table``: how the algorithm fares against the random-search
    baseline of its context ('baseline', 'beats it (p_holm=...)', 'does not beat it ...', or
    '' when the baseline was not run)."""
    out = []
    for _, r in stats_table.iterrows():
        ctx = stats_table[(stats_table["context"] == r["context"])
                          & (stats_table["optimizer"] == baseline)]
        if ctx.empty:
            out.append("")
            continue
        if r["optimizer"] == baseline:
            out.append("baseline")
            continue
        base = ctx["algorithm"].iloc[0]
        sel = pairs[(pairs["context"] == r["context"])
                    & (((pairs["a"] == r["algorithm"]) & (pairs["b"] == base))
                       | ((pairs["a"] == base) & (pairs["b"] == r["algorithm"])))]
        if sel.empty or not np.isfinite(sel["p_holm"].iloc[0]):
            out.append("not tested")
            continue
        p = sel["p_holm"].iloc[0]
        if sel["better"].iloc[0] == r["algorithm"]:
            out.append(f"beats it (p_holm={p:.2g})")
        elif sel["better"].iloc[0] == base:
            out.append(f"WORSE than it (p_holm={p:.2g})")
        else:
            out.append(f"does not clear it (p_holm={p:.2g})")
    return out
