"""Significance tests on the per-run metric (lower is better), from scipy.stats. Within a
context: Kruskal–Wallis, and every pair compared two-sided (Wilcoxon signed-rank where the
runs pair by instance, else Mann–Whitney U), Holm-corrected over the context's pairs; the
effect size is Vargha–Delaney's A12. Across blocks (contexts, or the instances of one):
Friedman, Nemenyi's post-hoc test and pairwise Wilcoxon with Holm. Too few groups, runs or
blocks give a note, not an error. Holm and Nemenyi are a few lines of numpy (the numbers of
statsmodels and scikit-posthocs, which the tests check): importing those libraries costs
more than the statistics themselves."""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import warnings
from typing import Any

import numpy as np

ALPHA = 0.05


def _quiet(f: Any, *args: Any, **kwargs: Any) -> Any:
    """``f(*args, **kwargs)``, scipy's warnings (ties, tiny samples) silenced: tables say why."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*args, **kwargs)


def a12_magnitude(a12: float) -> str:
    """Vargha and Delaney's (2000) labels for |A12 - 0.5|: 0.06, 0.14, 0.21 thresholds."""
    d = abs(a12 - 0.5)
    return next(label for limit, label in ((0.06, "negligible"), (0.14, "small"),
                                           (0.21, "medium"), (math.inf, "large")) if d < limit)


def holm(pvalues: list[float]) -> list[float]:
    """Holm–Bonferroni adjusted p-values: the i-th smallest of m finite p-values times
    ``m - i``, made non-decreasing in that order and capped at 1; NaN stays NaN."""
    p = np.asarray(pvalues, dtype=float)
    adjusted = np.full(p.shape, np.nan)
    ok = np.flatnonzero(np.isfinite(p))
    order = ok[np.argsort(p[ok], kind="stable")]
    adjusted[order] = np.minimum(np.maximum.accumulate(p[order] * np.arange(ok.size, 0, -1)), 1.0)
    return adjusted.tolist()


def nemenyi_friedman(values: np.ndarray) -> np.ndarray:
    """Nemenyi's post-hoc p-values of a (blocks x algorithms) table, a symmetric k x k
    matrix: each pair's difference of mean ranks over ``sqrt(k (k + 1) / (6 n))``, times
    ``sqrt(2)``, against the studentized range (k groups, infinite degrees of freedom)."""
    from scipy import stats

    v = np.asarray(values, float)
    n, k = v.shape
    mean_ranks = stats.rankdata(v, axis=1).mean(axis=0)
    iu = np.triu_indices(k, 1)
    q = np.abs(mean_ranks[iu[0]] - mean_ranks[iu[1]]) / np.sqrt(k * (k + 1.0) / (6.0 * n))
    out = np.ones((k, k))
    out[iu] = stats.studentized_range.sf(q * np.sqrt(2.0), k, np.inf)
    out[(iu[1], iu[0])] = out[iu]
    return out


def _ok(df: Any, value: str = "metric") -> Any:
    """The successful runs (failed runs carry no value) with a ``value``."""
    return df[(df["status"] == "ok") & df[value].notna()]


def _samples(df: Any, value: str = "metric") -> dict[str, np.ndarray]:
    """Per algorithm, ``value`` of the successful runs."""
    return {a: g[value].to_numpy(float) for a, g in _ok(df, value).groupby("algorithm")}


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
                res = _quiet(stats.kruskal, *usable.values())
                row["H"], row["p"] = float(res.statistic), float(res.pvalue)
                if not np.isfinite(row["p"]):
                    row["note"] = "undefined: all values are identical"
            except ValueError as exc:
                row["note"] = f"not run: {exc}"
        rows.append(row)
    return pd.DataFrame(rows)


def paired_by_instance(g: Any) -> bool:
    """Whether the runs of one context (a DataFrame) pair by instance: every successful run
    names an instance id (not just an index: identical instances give nothing to pair on)
    and no optimizer has two runs on one instance."""
    if "instance" not in g.columns:
        return False
    ok = g[g["status"] == "ok"]
    return (not ok.empty and all(isinstance(v, str) for v in ok["instance"])
            and not ok.duplicated(["algorithm", "instance"]).any())


#: Resamples of a permutation test (Monte Carlo when the exact enumeration is larger).
N_RESAMPLES = 9999


def _permutation(seed: int = 0) -> Any:
    from scipy.stats import PermutationMethod

    return PermutationMethod(n_resamples=N_RESAMPLES, rng=np.random.default_rng(seed))


def wilcoxon_paired(x: np.ndarray, y: np.ndarray) -> tuple[float, float, str]:
    """Two-sided Wilcoxon signed-rank test of paired ``x``, ``y``: (W, p, how p was got).
    Exact without ties or zero differences (n <= 50), all permutations with them for n <= 13,
    a seeded permutation test up to n = 50, else the normal approximation. Cached: a report
    tests the same pair twice (pairwise and within Friedman), and the result is a pure
    function of the values."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return _wilcoxon_cached(x.tobytes(), y.tobytes())


@functools.lru_cache(maxsize=4096)
def _wilcoxon_cached(xb: bytes, yb: bytes) -> tuple[float, float, str]:
    from scipy import stats

    x, y = np.frombuffer(xb, float), np.frombuffer(yb, float)
    d = x - y
    nz = d[d != 0]
    if nz.size == 0:
        return 0.0, 1.0, "all differences zero"
    ties = np.unique(np.abs(nz)).size < nz.size or nz.size < d.size
    if not ties and d.size <= 50:
        method, how = "exact", "exact"
    elif d.size <= 13:
        method, how = "auto", "exact (all permutations)"
    elif d.size <= 50:
        return (*_wilcoxon_permutation(d), f"permutation ({N_RESAMPLES} resamples)")
    else:
        method, how = "asymptotic", "normal approximation"
    res = _quiet(stats.wilcoxon, x, y, method=method)
    return float(res.statistic), float(res.pvalue), how


def _wilcoxon_permutation(d: np.ndarray) -> tuple[float, float]:
    """``scipy.stats.wilcoxon(x, y, method=_permutation())`` for the differences ``d`` (the
    same numbers, tested), vectorised over the sign flips: about 50 times faster than
    scipy's one call per resample. Zero differences are left out (``zero_method='wilcox'``)."""
    from scipy import stats

    nonzero = d != 0
    ranks = np.zeros_like(d)
    ranks[nonzero] = stats.rankdata(np.abs(d[nonzero]), method="average")

    def r_plus(flipped: np.ndarray, axis: int = -1) -> np.ndarray:
        return np.sum((flipped > 0) * ranks, axis=axis)

    res = stats.permutation_test((d,), r_plus, permutation_type="samples", vectorized=True,
                                 n_resamples=N_RESAMPLES, rng=np.random.default_rng(0),
                                 alternative="two-sided")
    statistic = min(np.sum((d > 0) * ranks), np.sum((d < 0) * ranks))
    return float(statistic), float(res.pvalue)


def mann_whitney(x: np.ndarray, y: np.ndarray) -> tuple[float, float, str]:
    """Two-sided Mann–Whitney U test: (U of ``x``, p, how p was got); exact without ties up to
    30 runs a sample, seeded permutations with ties up to 40 in all, else the normal law."""
    from scipy import stats

    ties = np.unique(np.concatenate([x, y])).size < len(x) + len(y)
    if not ties and max(len(x), len(y)) <= 30:
        method, how = "exact", "exact"
    elif ties and len(x) + len(y) <= 40 and min(len(x), len(y)) >= 2:  # scipy needs 2 each
        method, how = _permutation(), f"permutation ({N_RESAMPLES} resamples)"
    else:
        method, how = "asymptotic", "normal approximation"
    res = _quiet(stats.mannwhitneyu, x, y, alternative="two-sided", method=method)
    p = float(res.pvalue)
    # every value tied: no variance, no evidence of a difference
    return float(res.statistic), (1.0 if math.isnan(p) else p), how


def a12(x: np.ndarray, y: np.ndarray) -> float:
    """Vargha–Delaney A12 = P(X > Y) + P(X = Y)/2 over all pairs of the two samples."""
    x, y = np.asarray(x, float)[:, None], np.asarray(y, float)[None, :]
    return float(np.mean((x > y) + 0.5 * (x == y)))


#: Bootstrap resamples of an A12 interval (seeded: the report is a pure function of the runs).
N_BOOT = 1000


def a12_interval(x: np.ndarray, y: np.ndarray, paired: bool, level: float = 0.95,
                 seed: int = 0) -> tuple[float, float]:
    """A percentile bootstrap interval of A12(x, y), the instances resampled jointly when the
    samples pair by instance; ``(nan, nan)`` for an empty sample."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if not (x.size and y.size):
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    ix = rng.integers(0, x.size, (N_BOOT, x.size))
    iy = ix if paired and x.size == y.size else rng.integers(0, y.size, (N_BOOT, y.size))
    # A resample's A12 is cx^T S cy / (n m) with S the pair scores and c the draw counts:
    # exact (every term a multiple of 1/2), without a (resamples, n, m) array.
    score = (x[:, None] > y[None, :]) + 0.5 * (x[:, None] == y[None, :])
    boots = np.einsum("bi,ij,bj->b", _draw_counts(ix, x.size), score,
                      _draw_counts(iy, y.size)) / (x.size * y.size)
    tail = (1.0 - level) / 2.0
    lo, hi = np.quantile(boots, [tail, 1.0 - tail])
    return float(lo), float(hi)


def _draw_counts(idx: np.ndarray, n: int) -> np.ndarray:
    """How often each of ``n`` items was drawn in each row of ``idx``: shape (rows, n)."""
    rows = idx.shape[0]
    flat = (idx + n * np.arange(rows)[:, None]).ravel()
    return np.bincount(flat, minlength=rows * n).reshape(rows, n).astype(float)


def p_floor(method: str, two_sided: bool = True) -> float:
    """A permutation test's smallest p, ``1 / (N_RESAMPLES + 1)`` (doubled two-sided), else 0."""
    return ((2.0 if two_sided else 1.0) / (N_RESAMPLES + 1)
            if method.startswith("permutation") else 0.0)


def at_floor(p: float, method: str, two_sided: bool = True) -> bool:
    """Whether ``p`` is the permutation test's smallest (printed as a bound, ``p≤...``)."""
    floor = p_floor(method, two_sided)
    return bool(floor and math.isfinite(p) and p <= floor * (1 + 1e-9))


#: The name of each pairwise test as the tables give it.
TEST_PAIRED = "Wilcoxon signed-rank, paired by instance"
TEST_UNPAIRED = "Mann–Whitney U"


def pairwise_by_context(df: Any, alpha: float = ALPHA, value: str = "metric") -> Any:
    """Every pair of algorithms of each context compared on ``value``, two-sided,
    Holm-corrected within the context: Wilcoxon over the shared instances where the runs pair
    by instance, else Mann–Whitney U. A12 below 0.5: ``a`` tends to be better; ``better``:
    the lower of a significant pair."""
    import pandas as pd
    from scipy.stats import rankdata

    rows = []
    for context, g in df.groupby("context", sort=True):
        samples = _samples(g, value)
        paired = paired_by_instance(g)
        inst = {a: s.set_index("instance")[value].astype(float)  # per algorithm, by instance
                for a, s in _ok(g, value).groupby("algorithm")} if paired else {}
        block = []
        for a, b in itertools.combinations(sorted(samples), 2):
            x, y = samples[a], samples[b]  # each of one run at least
            effect = a12(x, y)
            row = {"context": context, "a": a, "b": b,
                   "test": TEST_PAIRED if paired else TEST_UNPAIRED, "p_method": "",
                   "n_a": len(x), "n_b": len(y), "n_pairs": np.nan,
                   "median_a": float(np.median(x)), "median_b": float(np.median(y)),
                   "U": np.nan, "W": np.nan, "p": np.nan, "A12": effect, "A12_lo": np.nan,
                   "A12_hi": np.nan, "effect": a12_magnitude(effect), "_lower": ""}
            if paired:
                common = inst[a].index.intersection(inst[b].index)
                row["n_pairs"] = len(common)
                if len(common):
                    xa, yb = inst[a][common].to_numpy(), inst[b][common].to_numpy()
                    row["A12_lo"], row["A12_hi"] = a12_interval(xa, yb, paired=True)
                    row["W"], row["p"], row["p_method"] = wilcoxon_paired(xa, yb)
                    d = xa - yb
                    r = rankdata(np.abs(d[d != 0])) if (d != 0).any() else np.zeros(0)
                    plus, minus = r[d[d != 0] > 0].sum(), r[d[d != 0] < 0].sum()
                    row["_lower"] = a if plus < minus else b if minus < plus else ""
            else:
                row["A12_lo"], row["A12_hi"] = a12_interval(x, y, paired=False)
                row["U"], row["p"], row["p_method"] = mann_whitney(x, y)
                row["_lower"] = a if row["A12"] < 0.5 else b if row["A12"] > 0.5 else ""
            block.append(row)
        for row, p_adj in zip(block, holm([r["p"] for r in block]), strict=True):
            row["p_holm"] = p_adj
            row["p_at_floor"] = at_floor(float(row["p"]), row["p_method"])
            row["significant"] = bool(np.isfinite(p_adj) and p_adj < alpha)
            lower = row.pop("_lower")
            row["better"] = lower if row["significant"] else ""
        rows.extend(block)
    cols = ["context", "a", "b", "test", "p_method", "n_a", "n_b", "n_pairs", "median_a",
            "median_b", "U", "W", "p", "p_holm", "p_at_floor", "A12", "A12_lo", "A12_hi",
            "effect", "significant", "better"]
    return pd.DataFrame(rows, columns=cols)


def compact_letters(order: list[str], different: set[frozenset[str]]) -> dict[str, str]:
    """Compact letter display (Piepho 2004, insert-and-absorb): two optimizers share a letter
    exactly when the tests do not separate them. ``order``: best first (it gets ``a``);
    ``different``: the significantly different pairs."""
    cols: list[frozenset[str]] = [frozenset(order)]
    for pair in sorted(different, key=lambda p: sorted(order.index(x) for x in p)):
        i, j = sorted(pair)
        split = [s for c in cols for s in ([c - {i}, c - {j}] if i in c and j in c else [c])]
        uniq = list(dict.fromkeys(c for c in split if c))
        cols = [c for c in uniq if not any(c < d for d in uniq)]
    rank = {name: k for k, name in enumerate(order)}
    cols.sort(key=lambda c: sorted(rank[x] for x in c))
    letters = "abcdefghijklmnopqrstuvwxyz"
    out = {name: "" for name in order}
    for k, c in enumerate(cols):
        letter = letters[k] if k < len(letters) else f"<{k}>"
        for name in sorted(c, key=rank.__getitem__):
            out[name] += letter
    return out


def rank_groups(pairs: Any, context: str, order: list[str]) -> dict[str, str]:
    """Letters of :func:`compact_letters` for one context (an untested pair is not separated)."""
    sub = pairs[(pairs["context"] == context) & pairs["significant"]]
    diff = {frozenset((r.a, r.b)) for r in sub.itertuples() if r.a in order and r.b in order}
    return compact_letters(order, diff)


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

    g = _ok(df[df["context"] == context])
    ranks = stats.rankdata(g["metric"].to_numpy(float))
    return g.assign(_rank=ranks).groupby("algorithm")["_rank"].mean().sort_values()


#: Friedman, Nemenyi and the block Wilcoxon tests need at least this many blocks.
MIN_BLOCKS = 5


@dataclasses.dataclass
class FriedmanResult:
    """Friedman's test over blocks (one value per block and algorithm) and its post-hoc tests."""

    blocks: list[str]
    algorithms: list[str]
    statistic: float = float("nan")
    p: float = float("nan")
    p_method: str = ""
    p_at_floor: bool = False  # p is the permutation test's smallest: a bound
    mean_ranks: Any = None  # Series algorithm -> mean rank (1 = best)
    nemenyi: Any = None  # DataFrame of p-values
    wilcoxon: Any = None  # DataFrame a, b, n_blocks, W, p, p_method, p_holm, significant
    note: str = ""
    kind: str = "contexts"  # what the blocks are: "contexts" or "instances"


def friedman_test(table: np.ndarray, seed: int = 0) -> tuple[float, float, str]:
    """Friedman's chi-square (scipy's, tie-corrected) and its permutation p-value, the values
    permuted within each block (all arrangements when at most N_RESAMPLES): (statistic, p,
    how p was got)."""
    from scipy import stats

    t = np.asarray(table, float)
    n, k = t.shape
    ranks = stats.rankdata(t, axis=1)

    def rank_sums(*samples: np.ndarray, axis: int = -1) -> np.ndarray:
        return np.sum(np.stack([np.sum(s, axis=axis) for s in samples]) ** 2, axis=0)

    res = stats.permutation_test(tuple(ranks.T), rank_sums, permutation_type="samples",
                                 alternative="greater", n_resamples=N_RESAMPLES,
                                 vectorized=True, rng=np.random.default_rng(seed))
    exact = math.factorial(k) ** n <= N_RESAMPLES
    how = "exact (all permutations)" if exact else f"permutation ({N_RESAMPLES} resamples)"
    return float(_quiet(stats.friedmanchisquare, *t.T).statistic), float(res.pvalue), how


def friedman_on_table(table: Any, alpha: float = ALPHA, kind: str = "contexts") -> FriedmanResult:
    """Friedman, Nemenyi and pairwise Wilcoxon (Holm) on a blocks x algorithms DataFrame,
    with at least :data:`MIN_BLOCKS` blocks and 3 algorithms (else a note says why not)."""
    import pandas as pd

    table = table.dropna(axis=1, how="any")
    blocks, algos = [str(b) for b in table.index], list(table.columns)
    res = FriedmanResult(blocks, algos, kind=kind)
    what = ("independent instances of the context" if kind == "instances" else
            "contexts such as problems or independent records")
    if len(blocks) < MIN_BLOCKS:
        res.note = (f"not run: needs at least {MIN_BLOCKS} blocks ({what}) in which the same "
                    f"optimizers ran; found {len(blocks)}")
        return res
    if len(algos) < 3:
        res.note = (f"not run: needs at least 3 optimizers present in every block; found "
                    f"{len(algos)}")
        return res
    values = table.to_numpy(float)
    res.mean_ranks = table.rank(axis=1, method="average").mean().sort_values()
    res.statistic, res.p, res.p_method = friedman_test(values)
    res.p_at_floor = at_floor(res.p, res.p_method, two_sided=False)
    res.nemenyi = pd.DataFrame(_quiet(nemenyi_friedman, values), index=algos, columns=algos)
    rows = []
    for a, b in itertools.combinations(algos, 2):
        x, y = table[a].to_numpy(float), table[b].to_numpy(float)
        w, p, how = wilcoxon_paired(x, y)
        rows.append({"a": a, "b": b, "n_blocks": len(x), "W": w, "p": p, "p_method": how,
                     "p_at_floor": at_floor(p, how)})
    for row, p_adj in zip(rows, holm([r["p"] for r in rows]), strict=True):
        row["p_holm"] = p_adj
        row["significant"] = bool(np.isfinite(p_adj) and p_adj < alpha)
    res.wilcoxon = pd.DataFrame(rows)
    if not np.isfinite(res.statistic):
        res.note = "undefined: the ranks are identical in every block"
    return res


def friedman_across_blocks(df: Any, alpha: float = ALPHA, value: str = "metric") -> FriedmanResult:
    """Friedman over contexts as blocks, on each algorithm's median ``value`` per context;
    not run where the contexts fit the same instances (not independent blocks)."""
    ok = _ok(df, value)
    medians = ok.groupby(["context", "algorithm"])[value].median().unstack("algorithm")
    if "instance" in ok.columns and len(medians) >= 2:
        sets = [frozenset(map(str, g["instance"])) for _, g in ok.groupby("context")]
        if all(s == sets[0] for s in sets) and all(isinstance(v, str) for v in ok["instance"]):
            return FriedmanResult([str(b) for b in medians.index], list(medians.columns),
                                  note="not run: the contexts fit the same instances, "
                                  "so they are not independent blocks (the instances of each "
                                  "context are)")
    return friedman_on_table(medians, alpha, "contexts")


def friedman_by_instances(df: Any, alpha: float = ALPHA, value: str = "metric"
                          ) -> dict[str, FriedmanResult]:
    """Per context whose runs pair by instance: Friedman with its instances as blocks."""
    out = {}
    for context, g in df.groupby("context", sort=True):
        if not paired_by_instance(g) or value not in g.columns:
            continue
        table = _ok(g, value).pivot(index="instance", columns="algorithm", values=value)
        out[str(context)] = friedman_on_table(table.dropna().astype(float), alpha, "instances")
    return out
