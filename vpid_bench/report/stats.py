"""Significance tests on the per-run metric, from scipy.stats, statsmodels and scikit-posthocs.

Within a context (one problem, one population size, one noise setting), the runs of different
optimizers are independent samples: Kruskal–Wallis tests whether any optimizer differs, and
every pair is compared with a two-sided Mann–Whitney U test, the p-values Holm-corrected over
all pairs of that context. The effect size is Vargha–Delaney's A12, computed from scipy's U.

Across contexts (blocks: population sizes, noise seeds, problems), each optimizer's median
per-run metric in each block is ranked within the block: the Friedman test asks whether the
ranks differ, Nemenyi's post-hoc test (scikit-posthocs) gives the pairs for the critical
difference diagram, and pairwise Wilcoxon signed-rank tests with Holm correction give a
second opinion. Too few groups, runs or blocks for a test give a note, not an error.

Lower metric is better everywhere (a problem metric, or the objective).
"""

from __future__ import annotations

import dataclasses
import itertools
import warnings
from typing import Any

import numpy as np

ALPHA = 0.05


def a12_from_u(u1: float, n1: int, n2: int) -> float:
    """Vargha–Delaney A12 = P(X > Y) + P(X = Y)/2 = U1 / (n1 n2), with U1 the Mann–Whitney
    statistic of the first sample (scipy's ``mannwhitneyu(x, y).statistic``)."""
    return float(u1) / (n1 * n2)


def a12_magnitude(a12: float) -> str:
    """Vargha and Delaney's (2000) labels for |A12 - 0.5|: 0.06, 0.14, 0.21 thresholds."""
    d = abs(a12 - 0.5)
    if d < 0.06:
        return "negligible"
    if d < 0.14:
        return "small"
    if d < 0.21:
        return "medium"
    return "large"


def holm(pvalues: list[float]) -> list[float]:
    """Holm–Bonferroni adjusted p-values (statsmodels ``multipletests(method='holm')``)."""
    if not pvalues:
        return []
    from statsmodels.stats.multitest import multipletests

    p = np.asarray(pvalues, dtype=float)
    adjusted = np.full(p.shape, np.nan)
    ok = np.isfinite(p)
    if ok.any():
        adjusted[ok] = multipletests(p[ok], method="holm")[1]
    return adjusted.tolist()


def _samples(df: Any) -> dict[str, np.ndarray]:
    """Per algorithm, the metric of the successful runs (failed runs carry no value)."""
    ok = df[(df["status"] == "ok") & df["metric"].notna()]
    return {a: g["metric"].to_numpy(float) for a, g in ok.groupby("algorithm", sort=True)}


def kruskal_by_context(df: Any) -> Any:
    """Kruskal–Wallis H test per context: columns context, k, n_per_group, H, p, note."""
    import pandas as pd
    from scipy import stats

    rows = []
    for context, g in df.groupby("context", sort=True):
        samples = _samples(g)
        sizes = ", ".join(f"{a}: {len(v)}" for a, v in samples.items())
        row = {"context": context, "k": len(samples), "n_per_group": sizes,
               "H": np.nan, "p": np.nan, "note": ""}
        usable = {a: v for a, v in samples.items() if len(v) >= 2}
        if len(usable) < 2:
            row["note"] = "not run: needs at least 2 optimizers with at least 2 runs each"
        else:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = stats.kruskal(*usable.values())
                row["H"], row["p"] = float(res.statistic), float(res.pvalue)
                if not np.isfinite(row["p"]):
                    row["note"] = "undefined: all values are identical"
            except ValueError as exc:
                row["note"] = f"not run: {exc}"
        rows.append(row)
    return pd.DataFrame(rows)


def pairwise_by_context(df: Any, alpha: float = ALPHA) -> Any:
    """Two-sided Mann–Whitney U for every pair of algorithms of each context, Holm-corrected
    within the context. Columns: context, a, b, n_a, n_b, median_a, median_b, U, p, p_holm,
    A12 (= P(metric_a > metric_b) + ties/2; below 0.5 means a tends to be better), effect,
    significant (p_holm < alpha), better (the algorithm with the lower median when
    significant, else empty)."""
    import pandas as pd
    from scipy import stats

    rows = []
    for context, g in df.groupby("context", sort=True):
        samples = _samples(g)
        block = []
        for a, b in itertools.combinations(sorted(samples), 2):
            x, y = samples[a], samples[b]
            row = {"context": context, "a": a, "b": b, "n_a": len(x), "n_b": len(y),
                   "median_a": float(np.median(x)) if len(x) else np.nan,
                   "median_b": float(np.median(y)) if len(y) else np.nan,
                   "U": np.nan, "p": np.nan, "A12": np.nan, "effect": ""}
            if len(x) and len(y):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = stats.mannwhitneyu(x, y, alternative="two-sided")
                row["U"], row["p"] = float(res.statistic), float(res.pvalue)
                row["A12"] = a12_from_u(res.statistic, len(x), len(y))
                row["effect"] = a12_magnitude(row["A12"])
            block.append(row)
        for row, p_adj in zip(block, holm([r["p"] for r in block]), strict=True):
            row["p_holm"] = p_adj
            row["significant"] = bool(np.isfinite(p_adj) and p_adj < alpha)
            better = ""
            if row["significant"]:
                better = row["a"] if row["A12"] < 0.5 else row["b"]
            row["better"] = better
        rows.extend(block)
    cols = ["context", "a", "b", "n_a", "n_b", "median_a", "median_b", "U", "p", "p_holm",
            "A12", "effect", "significant", "better"]
    return pd.DataFrame(rows, columns=cols)


def pvalue_matrix(pairs: Any, context: str) -> Any:
    """The Holm-corrected p-values of one context as a symmetric DataFrame (diagonal 1)."""
    import pandas as pd

    sub = pairs[pairs["context"] == context]
    names = sorted(set(sub["a"]) | set(sub["b"]))
    m = pd.DataFrame(1.0, index=names, columns=names)
    for _, r in sub.iterrows():
        p = r["p_holm"] if np.isfinite(r["p_holm"]) else 1.0
        m.loc[r["a"], r["b"]] = m.loc[r["b"], r["a"]] = p
    return m


def mean_ranks_in_context(df: Any, context: str) -> Any:
    """Mean rank (1 = lowest metric) of each algorithm's runs among all runs of ``context``."""
    from scipy import stats

    g = df[(df["context"] == context) & (df["status"] == "ok") & df["metric"].notna()]
    ranks = stats.rankdata(g["metric"].to_numpy(float))
    return g.assign(_rank=ranks).groupby("algorithm")["_rank"].mean().sort_values()


@dataclasses.dataclass
class FriedmanResult:
    """Friedman test across blocks (contexts) on each algorithm's median per-run metric."""

    blocks: list[str]
    algorithms: list[str]
    medians: Any = None  # DataFrame blocks x algorithms
    statistic: float = float("nan")
    p: float = float("nan")
    mean_ranks: Any = None  # Series algorithm -> mean rank (1 = best)
    nemenyi: Any = None  # DataFrame of p-values
    wilcoxon: Any = None  # DataFrame a, b, n_blocks, W, p, p_holm, significant
    note: str = ""


def friedman_across_blocks(df: Any, alpha: float = ALPHA) -> FriedmanResult:
    """Friedman over contexts as blocks, using the algorithms present in every block."""
    import pandas as pd
    import scikit_posthocs as sp
    from scipy import stats

    ok = df[(df["status"] == "ok") & df["metric"].notna()]
    medians = ok.groupby(["context", "algorithm"])["metric"].median().unstack("algorithm")
    medians = medians.dropna(axis=1, how="any")
    blocks, algos = list(medians.index), list(medians.columns)
    res = FriedmanResult(blocks, algos, medians)
    if len(blocks) < 2:
        res.note = ("not run: needs at least 2 blocks (contexts such as population sizes or "
                    f"noise seeds in which the same optimizers ran); found {len(blocks)}")
        return res
    if len(algos) < 3:
        res.note = (f"not run: needs at least 3 optimizers present in every block; found "
                    f"{len(algos)}")
        return res
    ranks = medians.rank(axis=1, method="average")
    res.mean_ranks = ranks.mean().sort_values()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fr = stats.friedmanchisquare(*[medians[a].to_numpy(float) for a in algos])
        res.statistic, res.p = float(fr.statistic), float(fr.pvalue)
        res.nemenyi = sp.posthoc_nemenyi_friedman(medians.to_numpy(float))
    res.nemenyi.index = res.nemenyi.columns = algos
    rows = []
    for a, b in itertools.combinations(algos, 2):
        x, y = medians[a].to_numpy(float), medians[b].to_numpy(float)
        row = {"a": a, "b": b, "n_blocks": len(x), "W": np.nan, "p": np.nan}
        if np.any(x != y):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                w = stats.wilcoxon(x, y)
            row["W"], row["p"] = float(w.statistic), float(w.pvalue)
        rows.append(row)
    for row, p_adj in zip(rows, holm([r["p"] for r in rows]), strict=True):
        row["p_holm"] = p_adj
        row["significant"] = bool(np.isfinite(p_adj) and p_adj < alpha)
    res.wilcoxon = pd.DataFrame(rows)
    if not np.isfinite(res.p):
        res.note = "undefined: the ranks are identical in every block"
    return res
