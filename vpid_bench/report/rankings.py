"""The second ranking, by search quality, and the words that compare it with the first (by
the problem's metric, which on a noisy record mixes how well an optimizer searches with where
the record's own optimum ``x*`` lies): the share of runs reaching their instance's optimum,
then the median ``rel_gap``, beside the median floor and distance to ``x*``. Its tests
compare ``max(rel_gap, 1e-6)``: runs that both reached the optimum tie. Numpy only."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .load import Rows, by_context, grouped
from .optima import REACHED, opt_column_names
from .render import fmt, joined, markdown, para
from .safe import escape
from .ties import WORDS_RTOL, same

#: A box whose centre lies within this relative distance of every true value is "centred".
CENTRED = 0.05
#: Two medians within this relative distance are tied in words (:data:`.ties.WORDS_RTOL`).
TIE_RTOL = WORDS_RTOL
#: The search-quality columns of the HTML pages and the CSV: (header, key of a search row).
SEARCH_COLUMNS = (("rank", "rank"), ("group", "group"), ("optimizer", "algorithm"),
                  ("n", "n"), ("reached x*", "reached"), ("share reached", "share"),
                  ("median rel_gap", "rel_gap_median"), ("floor", "floor_median"),
                  ("median distance to x* (%)", "to_opt_median"), ("AUC", "auc"))


def search_summary(rows: Rows) -> list[dict[str, Any]]:
    """Per context and algorithm, where every ok run knows its instance's optimum: n,
    reached, share, rel_gap_median, floor_median, to_opt_median and rank (largest share,
    then smallest median rel_gap first)."""
    floor_col, to_col = opt_column_names(rows)
    groups = grouped((r for r in rows if r["status"] == "ok"),
                     lambda r: (r["context"], r["algorithm"]))
    incomplete = {c for (c, _), g in groups.items()
                  if any(not math.isfinite(float(r.get("rel_gap", math.nan))) for r in g)}
    out = []
    for (context, algorithm), g in sorted(groups.items()):
        if context in incomplete:
            continue
        gaps = np.asarray([r["rel_gap"] for r in g], float)

        def med(col: str | None, g: Rows = g) -> float:
            v = np.asarray([r.get(col, math.nan) for r in g], float) if col else np.zeros(0)
            v = v[np.isfinite(v)]
            return float(np.median(v)) if v.size else math.nan

        reached = int(np.sum(gaps <= REACHED))
        out.append({"context": context, "algorithm": algorithm, "n": len(g),
                    "reached": reached, "share": reached / len(g),
                    "rel_gap_median": float(np.median(gaps)), "floor_median": med(floor_col),
                    "to_opt_median": med(to_col),
                    "floor_name": floor_col[: -len("_floor")] if floor_col else ""})
    out.sort(key=lambda s: (s["context"], -s["share"], s["rel_gap_median"], s["algorithm"]))
    for g in by_context(out).values():
        for i, s in enumerate(g, start=1):
            s["rank"] = i
    return out


def search_test_frame(df: Any) -> Any:
    """The runs with ``rel_gap_test = max(rel_gap, REACHED)``, what the search tests compare."""
    df = df.copy()
    df["rel_gap_test"] = np.maximum(df["rel_gap"].to_numpy(float), REACHED)
    df.loc[~np.isfinite(df["rel_gap"].to_numpy(float)), "rel_gap_test"] = np.nan
    return df


def box_centred(records: Rows, rows: Rows) -> dict[str, bool]:
    """Per context: is every record's box centred on its true values (within :data:`CENTRED`)?"""
    context = {r["run_id"]: r["context"] for r in rows}
    out: dict[str, bool] = {}
    for rec in records:
        p = rec.get("parameters") or {}
        lo, up, tr = p.get("lower"), p.get("upper"), p.get("true")
        ok = False
        try:
            if lo and up and tr and len(lo) == len(up) == len(tr):
                c = (np.asarray(lo, float) + np.asarray(up, float)) / 2
                t = np.asarray(tr, float)
                ok = bool(np.all(t != 0) and np.all(np.abs(c - t) <= CENTRED * np.abs(t)))
        except (TypeError, ValueError):
            ok = False
        key = context.get(rec["run_id"])
        if key is not None:
            out[key] = out.get(key, True) and ok
    return out


def disagreement(context: str, metric_name: str, metric_rows: Rows, search: Rows,
                 centred: bool, metric_groups: Mapping[str, str] | None = None) -> str:
    """Why the two rankings of a context differ beyond ties, in words (``""``: they agree).
    An optimizer ahead by the metric is said to stop early only when it reaches the optimum
    in fewer runs than one it passes and its median gap is above the reach threshold."""
    by_metric = {s["algorithm"]: s for s in metric_rows if s.get("n_runs")}
    srank = {s["algorithm"]: s for s in search}
    common = [a for a in by_metric if a in srank]
    m_order = sorted(common, key=lambda a: by_metric[a]["rank"])
    s_order = sorted(common, key=lambda a: srank[a]["rank"])

    def really_passes(a: str, b: str) -> bool:
        """a is ahead of b by the metric and behind it by search, beyond ties."""
        ma, mb = by_metric[a].get("median", math.nan), by_metric[b].get("median", math.nan)
        sa, sb = srank[a], srank[b]
        search_tie = (sa["reached"] == sb["reached"] and (
            same(sa["rel_gap_median"], sb["rel_gap_median"], TIE_RTOL)
            or max(sa["rel_gap_median"], sb["rel_gap_median"]) <= REACHED))
        return not same(ma, mb, TIE_RTOL) and not search_tie

    pairs = [(a, b) for a in m_order for b in m_order[m_order.index(a) + 1:]
             if s_order.index(b) < s_order.index(a) and really_passes(a, b)]
    if not pairs:
        return ""
    a = pairs[0][0]
    passed = [b for x, b in pairs if x == a]
    s = srank[a]
    text = (f"The rankings of {escape(context)} disagree beyond ties (medians within "
            f"{TIE_RTOL:g} relative count as equal): {escape(a)} ranks "
            f"{m_order.index(a) + 1} by {escape(metric_name)} but {s_order.index(a) + 1} by "
            f"search quality (it reaches the optimum in {s['reached']} of {s['n']} runs, "
            f"median rel_gap {fmt(s['rel_gap_median'], 3)}). ")
    if metric_groups:
        unseparated = [b for b in passed
                       if set(metric_groups.get(a, "")) & set(metric_groups.get(b, ""))]
        if unseparated:
            text += (f"By {escape(metric_name)} the tests do not separate it from "
                     f"{joined([escape(b) for b in unseparated])}, which it passes there. ")
    stops_short = s["rel_gap_median"] > REACHED and all(
        s["reached"] < srank[b]["reached"] or s["rel_gap_median"] > srank[b]["rel_gap_median"]
        for b in passed)
    floor, med = s["floor_median"], by_metric[a].get("median", math.nan)
    if stops_short and math.isfinite(floor) and math.isfinite(med) and med < floor:
        text += (f"Its median {escape(metric_name)} ({fmt(med, 3)}) is below the median floor "
                 f"({fmt(floor, 3)}), the {escape(metric_name)} of the record's own optimum: "
                 "its runs stop short of that optimum at points nearer the truth, which "
                 "searching better could not achieve")
        text += (": the search box is centred on the true values, so stopping early near its "
                 "centre scores well without searching well." if centred else ".")
    return text.rstrip()


def search_lines(context: str, search: Rows, groups: Mapping[str, str] | None,
                 metric_name: str, test: str | None) -> list[str]:
    """Markdown of one context's search-quality ranking (after its metric ranking)."""
    rows = [s for s in search if s["context"] == context]
    if not rows:
        return []
    h = ["rank", "group", "optimizer", "n", "reached", "median rel_gap", "median floor",
         "median to x*", "AUC"]
    body = [[s["rank"], (groups or {}).get(s["algorithm"], "—"), s["algorithm"], s["n"],
             f"{s['reached']}/{s['n']}", s["rel_gap_median"], s["floor_median"],
             s["to_opt_median"], s.get("auc", math.nan)] for s in rows]
    how = (f"`group`: optimizers sharing a letter are not separated by the Holm-corrected "
           f"pairwise tests ({escape(test)}) on max(rel_gap, {REACHED:g})" if test else
           "`group`: not tested in a single job's report")
    floor = rows[0].get("floor_name") or "rel_error"
    floor = metric_name if metric_name.lower() == floor else floor
    floor_text = (f"the {escape(floor)} of the instance's optimum x*" if floor != "rel_error" else
                  "the norm of x*'s relative errors against the true values, %")
    middle = (f"; the median floor ({floor_text}: what the record allows), the median "
              "distance to x* (percent of the true values)")
    if not any(math.isfinite(s["floor_median"]) or math.isfinite(s["to_opt_median"])
               for s in rows):  # no truth and no metric: the floor columns stay empty
        h, body = h[:6] + h[8:], [b[:6] + b[8:] for b in body]
        middle = ""
    return [para(f"By search quality: the share of runs reaching their instance's optimum "
                 f"(rel_gap <= {REACHED:g}), then the median rel_gap{middle} and the anytime "
                 f"AUC (area under the fixed-target ECDF, 0 to 1). {how}."), "",
            markdown(h, body, keep=6), ""]


def headline_groups_note(test: str | None, alpha: float) -> str:
    """The sentence under a metric ranking that says what ``group`` means."""
    if not test:
        return "`group`: not tested in a single job's report."
    return (f"`group`: optimizers sharing a letter are not separated by the Holm-corrected "
            f"pairwise tests ({escape(test)}, α={alpha}).")


def test_name(pairs: Any, context: str) -> str | None:
    """The pairwise test a context's table used (from :func:`.stats.pairwise_by_context`)."""
    if pairs is None or pairs.empty:
        return None
    sub = pairs[pairs["context"] == context]
    if sub.empty:
        return None
    methods = sorted(set(sub["p_method"]) - {""})
    return f"{sub['test'].iloc[0]}; p: {', '.join(methods)}" if methods else sub["test"].iloc[0]
