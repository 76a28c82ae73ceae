"""The report's first screen: per context, which optimizer, how far from the truth, and why.

The same :class:`ContextResult` feeds the top of ``report.md`` and the terminal, so the two
never disagree (the terminal no longer re-reads the Markdown). Per context:

* one ranking table by the problem's metric, with its unit, and beside it the search-quality
  columns where each instance's optimum is known (runs that reach it, the median gap to it);
* what the data allow: the floor (the metric of each instance's own optimum under the
  objective that was optimised, median over the instances) and the Cramér–Rao bound norm
  (what an efficient estimator could reach on such records);
* one verdict an engineer identifying a system can act on: whom to use, how far from the
  truth they end, and whether more search, a better estimator or better records would help.

Medians within :data:`TIE_RTOL` of each other are ties: a ranking that differs from the other
only within ties is never explained as anything.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..estimators import DESCRIPTION
from . import estimator_floors
from .body import verdict_short
from .optima import REACHED
from .rankings import TIE_RTOL
from .render import fmt, markdown, para, terminal
from .safe import clean, escape
from .tables import pair_detail

#: A leader whose median metric is within this factor of the floor has searched enough.
AT_FLOOR = 1.1
#: Two methods whose medians differ by more than this (relative) are not called equivalent
#: when the tests fail to separate them: the verdict says so.
EQUIVALENCE_MARGIN = 0.10
#: A floor this many times the bound means the estimator, not the data, limits accuracy.
ESTIMATOR_GAP = 2.0


@dataclasses.dataclass
class ContextResult:
    """The first screen of one context, as data."""

    context: str
    metric: str
    unit: str
    headers: list[str]
    rows: list[list[Any]]
    floor: float
    bound: float
    verdict: str
    tested: bool
    estimator: str | None = None  # the objective the runs minimised (problem.objective)
    floors: dict[str, Any] | None = None  # the floors of each estimator (estimators.json)
    pairs: list[dict[str, Any]] = dataclasses.field(default_factory=list)  # pairwise tests
    truth: bool = True  # False: the problem has no truth (a measured record)
    identified: Any = None  # without a truth: .estimates.Identified, the values and intervals
    comparisons: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    #: what biases the record's optimum, for a floor below the bound: the richer model that
    #: made the record (its description), and the instances whose optimum the box holds
    model_error: str = ""
    on_edge: tuple[int, int] = (0, 0)  # (instances with the optimum on a box edge, instances)

    def value(self, x: float) -> str:
        """A metric value with its unit."""
        return f"{fmt(x, 3)} {self.unit}".rstrip() if math.isfinite(x) else "n/a"


def _names(items: Sequence[str]) -> str:
    items = [escape(i) for i in items]
    if not items:
        return ""
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _lead(items: Sequence[Mapping[str, Any]], groups: Mapping[str, str] | None,
          value: str) -> list[Mapping[str, Any]]:
    """The best group of a ranking: the items sharing the first one's rank-group letter, or
    (untested) the first one and those tied with it within :data:`TIE_RTOL`."""
    if not items:
        return []
    first = items[0]
    if groups and groups.get(first["algorithm"]):
        letter = groups[first["algorithm"]][0]
        return [s for s in items if letter in groups.get(s["algorithm"], "")]
    return [s for s in items if tied(s.get(value, math.nan), first.get(value, math.nan))]


def tied(a: float, b: float) -> bool:
    """Whether two medians are equal within :data:`TIE_RTOL` (relative)."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return a == b
    return abs(a - b) <= TIE_RTOL * max(abs(a), abs(b), 1e-300)


def context_result(data: Any, context: str) -> ContextResult:
    """The first screen of ``context`` from a :class:`~.compute.ReportData`."""
    mrows = [s for s in data.metric_rows(context) if s.get("n_runs")]
    mrows.sort(key=lambda s: s["rank"])
    srows = {s["algorithm"]: s for s in data.search_rows(context)}
    metric = mrows[0]["metric_name"] if mrows else "metric"
    unit = data.unit(context)
    mgroups, sgroups = data.groups("metric", context), data.groups("search", context)
    label = f"median {metric}" + (f" ({unit})" if unit else "")
    headers = ["rank", "optimizer", "n", label, "IQR"]
    if mgroups is not None:
        headers.insert(1, "group")
    if srows:
        headers += ["reached x*", "median rel_gap", "search rank"]
    vs = f"vs_{data.baseline}"
    show_vs = any(s.get(vs) not in (None, "", "baseline", "not tested") for s in mrows)
    if show_vs:
        headers.append(f"beats {data.baseline}?")
    body = []
    for s in mrows:
        row: list[Any] = [s["rank"], s["algorithm"], s["n_runs"], s.get("median"),
                          f"[{fmt(s.get('q1'))}, {fmt(s.get('q3'))}]"]
        if mgroups is not None:
            row.insert(1, mgroups.get(s["algorithm"], "—"))
        q = srows.get(s["algorithm"])
        if srows:
            row += ([f"{q['reached']}/{q['n']}", q["rel_gap_median"],
                     f"{q['rank']}" + (f" ({sgroups.get(q['algorithm'], '')})" if sgroups
                                       else "")]
                    if q else ["", "", ""])
        if show_vs:
            row.append(verdict_short(s.get(vs) or ""))
        body.append(row)
    floors = [q["floor_median"] for q in srows.values() if math.isfinite(q["floor_median"])]
    floor = floors[0] if floors else math.nan
    bound = data.bounds.get(context, math.nan)
    pairs = ([] if data.tests is None or data.tests.pairs.empty else
             data.tests.pairs[data.tests.pairs["context"] == context].to_dict("records"))
    result = ContextResult(context, metric, unit, headers, body, floor, bound, "",
                           mgroups is not None, data.estimator(context),
                           data.estimator_floors.get(context), pairs,
                           not data.no_truth.get(context, False),
                           data.identified.get(context), data.comparisons.get(context, []))
    result.model_error, result.on_edge = _model_error(data, context), _edge(data, context)
    result.verdict = _verdict(result, mrows, [srows[a] for a in sorted(
        srows, key=lambda a: srows[a]["rank"])], mgroups, sgroups,
        data.centred.get(context, False))
    return result


def _model_error(data: Any, context: str) -> str:
    """What the richer model that made the context's records adds to the fitted one
    (``problem.info.model_error.what``, a short text from the records), or ``""``."""
    ids = {r["run_id"] for r in data.rows if r["context"] == context}
    for rec in data.loaded.records:
        if rec["run_id"] not in ids:
            continue
        info = (rec.get("problem") or {}).get("info")
        me = info.get("model_error") if isinstance(info, Mapping) else None
        what = me.get("what") if isinstance(me, Mapping) else None
        if isinstance(what, str) and what:
            return what[:300]
    return ""


def _edge(data: Any, context: str) -> tuple[int, int]:
    """(instances whose optimum lies on a box edge, instances with a known optimum)."""
    seen: dict[Any, float] = {}
    for r in data.rows:
        v = r.get("opt_on_edge", math.nan)
        if r["context"] == context and isinstance(v, float) and math.isfinite(v):
            seen[r.get("instance")] = v
    return int(sum(seen.values())), len(seen)


def _below_bound(res: ContextResult) -> str:
    """Why a floor can lie below the Cramér–Rao bound: the bound holds for unbiased
    estimators, and the record's optimum is biased by model error or by the box."""
    why = []
    if res.model_error:
        why.append(f"the record was made by a richer model than the fitted one "
                   f"({escape(res.model_error)}), which pulls the optimum to the fitted model's "
                   "best compromise, a bias the bound does not describe")
    k, n = res.on_edge
    if k:
        why.append(f"the box holds the optimum on an edge in {k} of {n} instance(s), "
                   "cutting the error there")
    if not why:
        why.append("neither model error nor the box is known to bias it here: the bound "
                   "linearises at the truth, and a median over few instances scatters")
    return (". The floor lies below the bound, which only unbiased estimators must respect: "
            + "; ".join(why))


def _verdict(res: ContextResult, mrows: list[Mapping[str, Any]],
             srows: list[Mapping[str, Any]], mgroups: Mapping[str, str] | None,
             sgroups: Mapping[str, str] | None, centred: bool) -> str:
    """One verdict: whom to use, how far from the truth, and what limits it."""
    if not mrows:
        return f"Verdict for {escape(res.context)}: no successful run to rank."
    mlead = _lead(mrows, mgroups, "median")
    slead = _lead(srows, sgroups, "rel_gap_median") if srows else []
    in_s = {q["algorithm"] for q in slead}
    both = [s["algorithm"] for s in mlead if s["algorithm"] in in_s]
    if both or not slead:
        pick = (both or [s["algorithm"] for s in mlead])[0]
        first = srows[0]["algorithm"] if srows else pick
        why = ("first by both rankings" if pick == mrows[0]["algorithm"] == first else
               "in the best group of both rankings" if both else f"best by {escape(res.metric)}")
        co = [s["algorithm"] for s in mlead if s["algorithm"] != pick]
    else:
        pick = slead[0]["algorithm"]
        why = "it gets closest to each record's own optimum"
        co = [q["algorithm"] for q in slead[1:]]
    test = "" if res.tested else "; untested, a single job's report"
    n = {s["algorithm"]: s["n_runs"] for s in mrows}
    if co:
        test += (f"; the tests do not separate it from {_names(co)} at {n.get(pick)} runs "
                 "each") + _not_equivalent(res, pick, co, mrows)
    test += _effect(res, pick, [s["algorithm"] for s in mrows])
    use = [pick]
    m = {s["algorithm"]: s["median"] for s in mrows}.get(pick, math.nan)
    if res.metric == "f_best":  # no accuracy metric: the problem knows no truth
        ends = f"It ends at a median objective value of {fmt(m, 4)}"
    elif not res.truth:
        ends = f"It ends at a median {escape(res.metric)} of {res.value(m)} (held out)"
    else:
        ends = f"It ends a median {res.value(m)} {escape(res.metric)} from the truth"
    text = f"Verdict for {escape(res.context)}: use {escape(pick)} ({why}{test}). {ends}"
    text += _limits(res, m, srows, use, centred)
    return text + "."


def _estimator(res: ContextResult) -> str:
    """The estimator a floor belongs to, in words: the objective the runs minimised."""
    if res.estimator is None:
        return "the objective that was optimised"
    words = DESCRIPTION.get(res.estimator)
    key = f"objective={escape(res.estimator)}"
    return f"{words} ({key})" if words else f"the objective {key}"


def _better(res: ContextResult) -> str:
    """``" (the likelihood's optimum: 0.95 % on the first 5 instances)"``, when another
    estimator's floor is known and lower."""
    if not res.floors:
        return ""
    best = estimator_floors.best_other(res.floors)
    if best is None or not best[1] < res.floor:
        return ""
    objective, value = best
    return (f" ({DESCRIPTION[objective]}, objective={objective}, has its optimum a median "
            f"{res.value(value)} from the truth on the first {res.floors['instances']} "
            "instance(s))")


def _not_equivalent(res: ContextResult, pick: str, co: Sequence[str],
                    mrows: Sequence[Mapping[str, Any]]) -> str:
    """``", though their medians differ by up to 56 % (more than the 10 % margin within
    which methods count as equivalent): more runs would tell"``, when a method the tests do
    not separate from the pick ends far from it; ``""`` otherwise."""
    med = {s["algorithm"]: float(s.get("median", math.nan)) for s in mrows}
    m = med.get(pick, math.nan)
    gaps = [abs(med[c] - m) / abs(m) for c in co
            if c in med and math.isfinite(med[c]) and math.isfinite(m) and m != 0]
    worst = max(gaps, default=0.0)
    if worst <= EQUIVALENCE_MARGIN:
        return ""
    return (f", though their medians differ by up to {fmt(100 * worst, 2)} % (more than the "
            f"{100 * EQUIVALENCE_MARGIN:g} % margin within which methods count as "
            "equivalent): more runs would tell")


def _effect(res: ContextResult, pick: str, ranked: Sequence[str]) -> str:
    """``"; against de6 p_holm=0.31, A12=0.45 [0.31, 0.60]"``: the effect size of the pick
    against the next optimizer of the ranking by the metric (A12 below 0.5: the pick tends to
    end lower), from the pairwise tests (none in a single job's report)."""
    others = [a for a in ranked if a != pick]
    if not others or not res.pairs:
        return ""
    other = others[0]
    row = next((r for r in res.pairs if {r["a"], r["b"]} == {pick, other}), None)
    if row is None or not math.isfinite(float(row.get("A12", math.nan))):
        return ""
    return f"; against {escape(other)}: {pair_detail(row, pick)}"


def _limits(res: ContextResult, m: float, srows: Sequence[Mapping[str, Any]],
            use: Sequence[str], centred: bool) -> str:
    """What limits the leaders: search, the estimator (objective) or the data."""
    floor, bound = res.floor, res.bound
    parts = []
    if not res.truth:
        return _limits_without_truth(res, m, srows, use)
    if math.isfinite(floor):
        parts.append(f"; the records allow {res.value(floor)} under {_estimator(res)} "
                     "(floor: its own optimum's error, median over the instances)")
    if math.isfinite(bound):
        parts.append(f", an efficient estimator {res.value(bound)} (Cramér–Rao bound norm)")
    if not math.isfinite(floor):
        return "".join(parts)
    if math.isfinite(bound) and floor < bound and not tied(floor, bound):
        parts.append(_below_bound(res))
    reached = [q for q in srows if q["algorithm"] in use]
    at_opt = any(q["reached"] >= q["n"] / 2 or q["rel_gap_median"] <= REACHED
                 for q in reached)
    if m < floor and not tied(m, floor) and not at_opt:
        parts.append(". Ending below the floor is not better search: the runs stopped short "
                     "of the optimum" + (" in a box centred on the truth" if centred else ""))
    elif at_opt or m <= AT_FLOOR * floor:
        parts.append(". More search will not help here")
        if math.isfinite(bound) and bound > 0 and floor > ESTIMATOR_GAP * bound \
                and res.model_error:
            parts.append(f": the floor is {fmt(floor / bound, 2)}× the bound, and the record was "
                         f"made by a richer model than the fitted one ({escape(res.model_error)}"
                         "): model error, which no estimator of the fitted model removes, may "
                         "set it; a richer fitted model would")
        elif math.isfinite(bound) and bound > 0 and floor > ESTIMATOR_GAP * bound:
            parts.append(f": the objective, not the data, sets the floor ({fmt(floor / bound, 2)}"
                         "× the bound), so a better estimator would" + _better(res))
        else:
            parts.append(": better records would (longer, other inputs or sensors)")
    elif floor > 0:
        parts.append(f". A larger budget or a better optimizer would still gain: the leaders "
                     f"end {fmt(m / floor, 2)}× above the floor")
    else:  # a floor of exactly 0 (noise-free records: the optimum is the truth), no ratio
        parts.append(". A larger budget or a better optimizer would still gain: the records "
                     "allow the truth itself, and the leaders end "
                     f"{res.value(m)} from it")
    return "".join(parts)


def _limits_without_truth(res: ContextResult, m: float, srows: Sequence[Mapping[str, Any]],
                          use: Sequence[str]) -> str:
    """Without a truth: whether the leaders reach the record's optimum of the objective, and
    what that optimum scores by the headline metric (held out) where there is one."""
    reached = [q for q in srows if q["algorithm"] in use]
    if not reached:
        return ""
    at_opt = any(q["reached"] >= q["n"] / 2 or q["rel_gap_median"] <= REACHED
                 for q in reached)
    text = ("; it reaches the record's optimum of the objective, so more search will not "
            "change the answer" if at_opt else
            f"; it stops a median relative gap of {fmt(reached[0]['rel_gap_median'], 3)} "
            "above the record's optimum of the objective: more search would still move it")
    if res.metric != "f_best" and math.isfinite(res.floor):
        text += (f" (the optimum scores {res.value(res.floor)} {escape(res.metric)}"
                 + (": a better objective value does not always predict better"
                    if res.floor > m and not tied(res.floor, m) else "") + ")")
    return text


def _no_truth_lines(r: ContextResult) -> list[tuple[str, list[str], list[list[Any]]]]:
    """The paragraphs and tables a context without a truth adds below its ranking:
    ``(text, headers, rows)`` (empty headers: text only)."""
    from .estimates import NO_TRUTH

    out: list[tuple[str, list[str], list[list[Any]]]] = []
    ranked = ("the objective" if r.metric == "f_best" else
              f"{escape(r.metric)} (held out) and, in the search columns, by the objective")
    out.append((f"{NO_TRUTH}; ranked by {ranked}.", [], []))
    ident = r.identified
    if ident is not None:
        sigma = ", ".join(fmt(s, 3) for s in ident.sigma)
        text = (f"Identified values: the best run ({escape(ident.run)}, objective "
                f"{fmt(ident.f, 4)}), with 95 % intervals from the Jacobian of its residuals "
                f"under Gaussian noise of σ estimated from them per residual group ({sigma}, "
                "in the residuals' units); model error counts as noise there. ")
        text += ("The profile likelihood drops the linearisation: its interval is around the "
                 "likelihood's own estimate (Gaussian noise, σ per group as above), which "
                 "differs from the best run where the objective is not that likelihood."
                 if ident.profile is not None
                 else escape(ident.profile_note) + ".")
        headers, rows = ident.rows()
        out.append((text, headers, rows))
    if r.comparisons:
        names: list[str] = []
        for c in r.comparisons:
            names += [k for k in c["metrics"] if k not in names]
        headers = ["comparison (not a run, not a truth)", "objective", *names, "note"]
        rows = [[escape(c["name"]), c["f"], *[c["metrics"].get(k) for k in names],
                 escape(c["note"])] for c in r.comparisons]
        out.append(("Fixed rows the problem gives for comparison (a published estimate, a "
                    "predictor a model must beat): never a truth.", headers, rows))
    return out


def results(data: Any) -> list[ContextResult]:
    """The first screen of every context, in report order."""
    return [context_result(data, c) for c in data.contexts]


def markdown_lines(items: Sequence[ContextResult]) -> list[str]:
    """The Results section of ``report.md`` (its first screen)."""
    lines = ["## Results", ""]
    for r in items:
        unit = f" ({escape(r.unit)})" if r.unit else ""
        floor = "floor" if r.truth else "the objective's optimum scores"
        levels = [f"{what} {r.value(v)}" for what, v in ((floor, r.floor), ("bound", r.bound))
                  if math.isfinite(v)]
        lines += [f"### {escape(r.context)}", "",
                  para(f"Ranked by {escape(r.metric)}{unit}, lower is better"
                       + (f" ({', '.join(levels)})." if levels else ".")), "",
                  markdown(r.headers, r.rows, keep=5), ""]
        for text, headers, rows in extra_blocks(r):
            lines += [para(text), ""] + ([markdown(headers, rows), ""] if headers else [])
        lines += [para(r.verdict), ""]
    return lines


def extra_blocks(r: ContextResult) -> list[tuple[str, list[str], list[list[Any]]]]:
    """What every renderer shows below a context's ranking: for a context without a truth,
    the identified values with their intervals and the problem's comparison rows, as
    ``(Markdown text, headers, rows)`` (empty headers: text only); nothing otherwise."""
    return [] if r.truth else _no_truth_lines(r)


def terminal_text(items: Sequence[ContextResult]) -> str:
    """The same first screen for the terminal: a table and a verdict per context."""
    blocks = []
    for r in items:
        extra = ""
        for text, headers, rows in extra_blocks(r):
            extra += clean(" ".join(text.split())) + "\n" + (
                terminal(headers, rows) + "\n" if headers else "")
        blocks.append(f"{clean(r.context)}\n" + terminal(r.headers, r.rows) + "\n" + extra
                      + clean(" ".join(r.verdict.split())))
    return "\n\n".join(blocks)
