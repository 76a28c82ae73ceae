"""The report's first screen, per context: the ranking (with the search-quality columns where
each instance's optimum is known), the floor and Cramér–Rao bound, and the verdict in words
(:mod:`.verdicts` decides it). One :class:`ContextResult` feeds ``report.md`` and the
terminal, so the two never disagree."""

from __future__ import annotations

import dataclasses
import math
import re
import shutil
import textwrap
from collections.abc import Mapping, Sequence
from typing import Any

from ..estimators import DESCRIPTION
from . import anytime, assumed, diagnostics, verdicts
from .answer import sentences, table_note
from .body import verdict_short
from .estimates import NO_TRUTH, NO_TRUTH_NO_RECORD
from .render import PROSE_WIDTH, fmt, joined, markdown, para, terminal
from .safe import clean, escape, shown
from .tables import pair_detail
from .verdicts import Verdict


@dataclasses.dataclass
class ContextResult:
    """The first screen of one context, as data: its table and its verdict."""

    context: str
    metric: str
    unit: str
    headers: list[str]
    rows: list[list[Any]]
    floor: float
    bound: float
    verdict: str  # in words, Markdown-escaped (:func:`verdict_text` of ``decision``)
    tested: bool
    decision: Verdict | None = None  # the verdict as data, with its reasons (:mod:`.verdicts`)
    truth: bool = True  # False: the problem has no truth (a measured record)
    identified: Any = None  # without a truth: .estimates.Identified, the values and intervals
    comparisons: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    #: the stated quantities, boxes and input the answer depends on (:mod:`.assumed`)
    assumed: list[Any] = dataclasses.field(default_factory=list)
    #: the fit diagnostics at the context's optimum (:mod:`.diagnostics`), or None
    diagnostics: Any = None
    model_error: str = ""  # what the richer model that made the record adds, or ""
    #: False where the context's records say their problem fits no record (N16)
    fits_a_record: bool = True

    def value(self, x: float) -> str:
        return _value(x, self.unit, escape)


#: Record text in a verdict is marked (``_name``) so that the terminal never breaks a line
#: inside it (a hostile name starting a line could look like a table row).
_OPEN, _CLOSE = "\x02", "\x03"
_MARKED = re.compile(f"{_OPEN}(.*?){_CLOSE}", re.S)


def _name(text: Any) -> str:
    """Record text for a verdict: Markdown-escaped and marked (see :data:`_OPEN`)."""
    return f"{_OPEN}{escape(text)}{_CLOSE}"


def _unmarked(text: str, glue: str = " ") -> str:
    """``text`` without the marks, the spaces inside marked names replaced by ``glue``."""
    return _MARKED.sub(lambda m: m.group(1).replace(" ", glue), text)


def _value(x: float, unit: str, name: Any = None) -> str:
    """``x`` with its unit (record text: marked by default, see :func:`_name`)."""
    if not math.isfinite(x):
        return "n/a"
    return f"{fmt(x, 3)} {(name or _name)(unit)}" if unit else fmt(x, 3)


def _names(items: Sequence[str]) -> str:
    return joined([_name(i) for i in items])


def _ref(name: str) -> str:
    words = verdicts.REFERENCE_WORDS.get(name)
    return f"{words} ({name})" if words else _name(name)


def context_result(data: Any, context: str) -> ContextResult:
    """The first screen of ``context`` from a :class:`~.compute.ReportData`."""
    mrows, srows = _rows(data, context)
    v = verdicts.decide(evidence(data, context))
    mgroups, sgroups = data.groups("metric", context), data.groups("search", context)
    label = f"median {v.metric}" + (f" ({v.unit})" if v.unit else "")
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
        row: list[Any] = [s.get("rank_shown", s["rank"]), s["algorithm"], s["n_runs"],
                          s.get("median"),
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
    return ContextResult(context, v.metric, v.unit, headers, body, v.floor, v.bound,
                         verdict_text(v), mgroups is not None, v, v.truth,
                         data.identified.get(context), data.comparisons.get(context, []),
                         assumed.blocks(data, context),
                         getattr(data, "diagnostics", {}).get(context), v.model_error,
                         assumed.fits_a_record(data, context))


def _rows(data: Any, context: str) -> tuple[list[dict[str, Any]], dict[str, dict[str, Any]]]:
    """The context's metric rows with runs, best first, and its search rows by optimizer."""
    mrows = sorted((s for s in data.metric_rows(context) if s.get("n_runs")),
                   key=lambda s: s["rank"])
    return mrows, {s["algorithm"]: s for s in data.search_rows(context)}


def evidence(data: Any, context: str) -> verdicts.Evidence:
    """What the verdict of ``context`` rests on."""
    mrows, srows = _rows(data, context)
    mgroups = data.groups("metric", context) or {}
    sgroups = data.groups("search", context) or {}
    cost = {a: v for (c, a), v in anytime.costs_to_optimum(data.hits).items() if c == context}
    methods = []
    for s in mrows:
        q = srows.get(s["algorithm"])
        search = None if q is None else verdicts.Search(
            q["reached"], q["n"], q["rel_gap_median"], sgroups.get(q["algorithm"], ""),
            *cost.get(q["algorithm"], (math.inf, math.nan)))
        methods.append(verdicts.Method(s["algorithm"], s["n_runs"],
                                       float(s.get("median", math.nan)),
                                       mgroups.get(s["algorithm"], ""), search))
    refs = [data.baseline, *verdicts.REFERENCES]
    present = {s["optimizer"]: s["algorithm"] for s in mrows}
    pairs = ([] if data.tests is None or data.tests.pairs.empty else
             data.tests.pairs[data.tests.pairs["context"] == context].to_dict("records"))
    floors = data.floors(context)
    bounds = data.instance_bounds.get(context)
    if not bounds:  # a file without each instance's bound: its design's, for every instance
        bound = data.bounds.get(context, math.nan)
        bounds = ({k: bound for k in floors} if floors else {None: bound}) \
            if math.isfinite(bound) else {}
    return verdicts.Evidence(
        context, mrows[0]["metric_name"] if mrows else "metric", data.unit(context),
        tuple(methods), data.tests is not None, tuple(pairs), floors, bounds,
        data.estimator(context), data.estimator_floors.get(context),
        tuple(dict.fromkeys(present[r] for r in refs if r in present)),
        tuple(dict.fromkeys(r for r in refs if r not in present)),
        data.centred.get(context, False), not data.no_truth.get(context, False),
        _model_error(data, context), _edge(data, context))


def _model_error(data: Any, context: str) -> str:
    """What the richer model that made the records adds (``problem.info.model_error``)."""
    for rec in data.records_of(context):
        info = (rec.get("problem") or {}).get("info")
        me = info.get("model_error") if isinstance(info, Mapping) else None
        what = me.get("what") if isinstance(me, Mapping) else None
        if isinstance(what, str) and what:
            fit = me.get("fit_with")  # the richer fitted structure, where the problem has one
            return (what[:300] + (f"; fitted with it by {fit[:200]}" if isinstance(fit, str)
                                  and fit else ""))
    return ""


def _edge(data: Any, context: str) -> tuple[int, int]:
    """(instances whose optimum lies on a box edge, instances with a known optimum)."""
    seen = {r.get("instance"): v for r in data.rows if r["context"] == context
            and isinstance(v := r.get("opt_on_edge", math.nan), float) and math.isfinite(v)}
    return int(sum(seen.values())), len(seen)


def results(data: Any) -> list[ContextResult]:
    """The first screen of every context, in report order."""
    return [context_result(data, c) for c in data.contexts]


def verdict_text(v: Verdict) -> str:
    """The verdict of one context in words (one paragraph; record text escaped)."""
    return _unmarked(_marked_verdict(v))


def _marked_verdict(v: Verdict) -> str:
    head = f"Verdict for {_name(v.context)}: "
    if v.kind == verdicts.EMPTY:
        return head + "no successful run to rank."
    if v.kind == verdicts.DESCRIBE:
        why = ("only one optimizer ran" if v.single else
               "no tests were run (a single job's report)")
        text = (f"{head}a description, not a recommendation ({why}). "
                f"{_ends(v, _name(v.pick))} over {v.runs} run(s)")
    elif v.kind == verdicts.NONE and v.cannot_identify:  # rule 5
        text = (f"{head}the fitted model cannot identify the true system from this record (a "
                f"richer model made it). The lowest median {_name(v.metric)}: "
                f"{_ends(v, _name(v.pick))}")
    elif v.kind == verdicts.NONE:
        # Only the bound says that nothing can identify the model; tests that separate no
        # method from the references say only that none is shown to (more runs may tell).
        lead = ("no method identifies this model from this record" if v.over_bound else
                "no method is shown to identify this model from this record")
        text = (f"{head}{lead}{_unidentified(v)}. "
                f"The lowest median {_name(v.metric)}: {_ends(v, _name(v.pick))}")
    else:
        text = (f"{head}use {_name(v.pick)} ({_why(v)}{_effect(v)}{_missing(v)}). "
                f"{_ends(v, 'It')}")
    return text + _limits(v) + "."


def _ends(v: Verdict, who: str) -> str:
    if v.metric == "f_best":  # no accuracy metric: the problem knows no truth
        return f"{who} ends at a median objective value of {fmt(v.median, 4)}"
    if not v.truth:
        return (f"{who} ends at a median {_name(v.metric)} of {_value(v.median, v.unit)} "
                "(held out)")
    return f"{who} ends a median {_value(v.median, v.unit)} {_name(v.metric)} from the truth"


def _unidentified(v: Verdict) -> str:
    """``": the Cramér–Rao bound ... and no optimizer is separated from ..."``."""
    parts = []
    if v.over_bound:
        parts.append(f"the Cramér–Rao bound norm is {_value(v.bound, v.unit)}, above "
                     f"{verdicts.BOUND_LIMIT:g} %: even an efficient estimator would miss the "
                     "parameters by more than their own size")
    refs = [_ref(r) for r in v.not_beaten]
    tests = f"by the Holm-corrected pairwise tests at {v.runs} runs each"
    if refs:
        parts.append(f"no optimizer is separated from {' or '.join(refs)} {tests}")
    elif not v.over_bound:
        parts.append("no optimizer is separated from each of "
                     + " and ".join(_ref(r) for r in v.references) + f" {tests}")
    return ": " + "; and ".join(parts) if parts else ""


def _why(v: Verdict) -> str:
    """Why the pick: how rule 3 chose it, in words."""
    metric = _name(v.metric)
    tied = (f"the tests do not separate it from {_names(v.tied)} by {metric} at {v.runs} "
            "runs each" + _not_equivalent(v)) if v.tied else ""
    if v.basis == verdicts.SEARCH_ONLY:
        one = len(v.leaders) == 1
        return ("it gets closest to each record's own optimum"
                + (f"; {_names(v.leaders)} {'ends' if one else 'end'} nearer the truth by "
                   f"{metric} but {'searches' if one else 'search'} worse" if v.leaders else "")
                + _cost_words(v))
    if v.basis == verdicts.ALONE:
        return f"alone in the best group by {metric}"
    if v.basis == verdicts.SEARCH:
        return f"{tied}; it searches better (the best group by search quality)"
    if v.basis == verdicts.COST:
        return (f"{tied}; tied with {_names([c.name for c in v.costs[1:]])} by search quality "
                f"too, it reaches the optimum sooner{_cost_words(v)}")
    return f"{tied}; the first of them by the median"


def _cost_words(v: Verdict) -> str:
    """``": 23.7 evaluations to it (ERT) against 130 for de_lsq; 0.02 s against ..."``."""
    if len(v.costs) < 2:
        return ""
    me, others = v.costs[0], v.costs[1:]

    def listing(key: str, unit: str) -> str:
        return ", ".join(f"{fmt(getattr(c, key), 3)}{unit} for {_name(c.name)}"
                         for c in others)
    text = (f": {fmt(me.evaluations, 3)} evaluations to it (ERT) against "
            f"{listing('evaluations', '')}")
    if math.isfinite(me.seconds):
        text += f"; {fmt(me.seconds, 3)} s against {listing('seconds', ' s')}"
    return text


def _not_equivalent(v: Verdict) -> str:
    """``", though their medians differ by up to 56 % (...): more runs would tell"``."""
    if v.spread <= verdicts.EQUIVALENCE_MARGIN:
        return ""
    return (f", though their medians differ by up to {fmt(100 * v.spread, 2)} % (more than the "
            f"{100 * verdicts.EQUIVALENCE_MARGIN:g} % margin within which methods count as "
            "equivalent): more runs would tell")


def _effect(v: Verdict) -> str:
    """``"; against de6: p_holm=0.31, A12=0.45 [0.31, 0.60]"``: the pick against the next."""
    row = v.next_pair
    if row is None or not math.isfinite(float(row.get("A12", math.nan))):
        return ""
    return f"; against {_name(v.next_name)}: {pair_detail(row, v.pick)}"


def _missing(v: Verdict) -> str:
    if not v.missing:
        return ""
    one = len(v.missing) == 1
    return (f"; {' and '.join(_ref(r) for r in v.missing)} {'was' if one else 'were'} not "
            f"run: nothing here shows that {_name(v.pick)} beats {'it' if one else 'them'}")


def _estimator(v: Verdict) -> str:
    """The estimator a floor belongs to, in words: the objective the runs minimised."""
    if v.estimator is None:
        return "the objective that was optimised"
    words = DESCRIPTION.get(v.estimator)
    key = f"objective={_name(v.estimator)}"
    return f"{words} ({key})" if words else f"the objective {key}"


def _limits(v: Verdict) -> str:
    """What the records allow, and what limits the leader: search, the estimator or the data."""
    if not v.truth:
        return _limits_without_truth(v)
    parts = [_allowed(v)]
    if v.cannot_identify:  # rule 5: no reading of search as identification follows
        return parts[0] + _cannot_identify(v)
    if v.below_bound:
        parts.append(_below_bound(v))
    if v.limit == verdicts.LIMIT_BELOW:
        parts.append(". Ending below the floor is not better search: the runs stopped short "
                     "of the optimum" + (" in a box centred on the truth" if v.centred else ""))
        if v.model_error:
            parts.append(f", which model error has pulled off the truth (the record was made "
                         f"by a richer model: {_name(v.model_error)}): ending nearer the "
                         "truth with a worse fit is chance, not identification")
    elif v.limit == verdicts.LIMIT_TRUTH:  # a floor of 0: noise-free records
        parts.append(". A larger budget or a better optimizer would still gain: the records "
                     "allow the truth itself")
    elif v.limit == verdicts.LIMIT_SEARCH:
        parts.append(f". A larger budget or a better optimizer would still gain: the leader "
                     f"ends {fmt(v.gain, 2)}× above the floor")
    elif v.limit == verdicts.LIMIT_ESTIMATOR:
        parts.append(". More search will not help here")
    elif v.limit == verdicts.LIMIT_MODEL:
        parts.append(f". More search will not help here: the floor is {fmt(v.ratio, 2)}× the "
                     "bound, and the record was made by a richer model than the fitted one "
                     f"({_name(v.model_error)}): model error, which no estimator of the fitted "
                     "model removes, may set it; a richer fitted model would")
    elif v.limit == verdicts.LIMIT_RECORDS:
        parts.append(". More search will not help here: better records would (longer, other "
                     "inputs or sensors)")
    if v.advice is not None:
        parts.append(_advice(v, v.advice))
    return "".join(parts)


def _allowed(v: Verdict) -> str:
    """The floor and the bound of a context with a truth, in words."""
    parts = []
    if math.isfinite(v.floor):
        parts.append(f"; the records allow {_value(v.floor, v.unit)} under {_estimator(v)} "
                     "(floor: its own optimum's error, median over the instances)")
    if math.isfinite(v.bound):
        lo, hi = v.bound_range
        spread = (f", median of each instance's own, {fmt(lo, 3)} to {fmt(hi, 3)}"
                  if hi > lo * (1 + 1e-6) else "")
        parts.append(f", an efficient estimator {_value(v.bound, v.unit)} (Cramér–Rao bound "
                     f"norm{spread})")
    return "".join(parts)


def _cannot_identify(v: Verdict) -> str:
    """Rule 5 in words: the fitted model cannot identify the true system (model error)."""
    refs = ", ".join(f"{_name(n)} ends at {_value(m, v.unit)}" for n, m in v.cannot_identify)
    return (f". The fitted model cannot identify the true system: the record's own optimum lies "
            f"farther from the truth than a reference ({refs}), because a richer model made "
            f"the record ({_name(v.model_error)}). Reaching that optimum is search, not "
            "identification, and no optimizer is credited for it here; a richer fitted "
            "structure is needed")


def _below_bound(v: Verdict) -> str:
    """Why a floor can lie below the Cramér–Rao bound (which holds for unbiased estimators)."""
    why = []
    if v.model_error:
        why.append(f"the record was made by a richer model than the fitted one "
                   f"({_name(v.model_error)}), which pulls the optimum to the fitted model's "
                   "best compromise, a bias the bound does not describe")
    k, n = v.on_edge
    if k:
        why.append(f"the box holds the optimum on an edge in {k} of {n} instance(s), "
                   "cutting the error there")
    if not why:
        why.append("neither model error nor the box is known to bias it here: the bound "
                   "linearises at the truth, and a median over few instances scatters")
    return (". The floor lies below the bound, which only unbiased estimators must respect: "
            + "; ".join(why))


def _advice(v: Verdict, a: verdicts.EstimatorAdvice) -> str:
    """The estimator as the bottleneck, and what the best other estimator gains."""
    text = (f". The estimator is the bottleneck: its floor is {fmt(a.ratio, 2)}× the Cramér–Rao "
            "bound (median per instance)")
    if a.better is not None:
        gain = (f", {fmt(a.chosen_floor / a.better_floor, 2)}× closer"
                if math.isfinite(a.chosen_floor) and a.better_floor > 0 else "")
        return (text + f"; problem.objective={_name(a.better)} "
                f"({DESCRIPTION.get(a.better, 'another estimator')}) has its optimum a median "
                f"{_value(a.better_floor, v.unit)} from the truth on the first {a.instances} "
                f"instance(s){gain}")
    if a.instances:
        return text + (f"; no other built-in estimator's optimum lies closer on the first "
                       f"{a.instances} instance(s)")
    return text + ": an estimator that weighs the samples by their noise (a likelihood) would gain"


def _limits_without_truth(v: Verdict) -> str:
    """Without a truth: whether the leader reaches the record's optimum, and what that
    optimum scores by the headline metric (held out)."""
    if v.search is None:
        return ""
    text = ("; it reaches the record's optimum of the objective, so more search will not "
            "change the answer" if v.search.at_optimum else
            f"; it stops a median relative gap of {fmt(v.search.rel_gap_median, 3)} "
            "above the record's optimum of the objective: more search would still move it")
    if v.metric != "f_best" and math.isfinite(v.floor):
        text += (f" (the optimum scores {_value(v.floor, v.unit)} {_name(v.metric)}"
                 + (": a better objective value does not always predict better"
                    if v.floor > v.median and not verdicts.tied(v.floor, v.median) else "")
                 + ")")
    return text


def _no_truth_lines(r: ContextResult) -> list[tuple[str, list[str], list[list[Any]]]]:
    """The paragraphs and tables a context without a truth adds below its ranking."""
    ranked = ("the objective" if r.metric == "f_best" else
              f"{escape(r.metric)} (held out) and, in the search columns, by the objective")
    out: list[tuple[str, list[str], list[list[Any]]]] = [
        (f"{NO_TRUTH if r.fits_a_record else NO_TRUTH_NO_RECORD}; ranked by {ranked}.", [], [])]
    ident = r.identified
    if ident is not None:
        sigma = ", ".join(fmt(s, 3) for s in ident.sigma)
        text = (f"Identified values: the best run ({escape(ident.run)}, objective "
                f"{_objective(ident)}), with 95 % intervals from the Jacobian of its residuals "
                f"under Gaussian noise of σ estimated from them per residual group ({sigma}, "
                "in the residuals' units); model error counts as noise there, and they "
                "assume white residuals"
                + ("; the robust (HAC) interval, in the fit diagnostics below, does not. " if
                   ident.robust_lower is not None else ". "))
        if ident.caveat:
            text += escape(ident.caveat) + " "
        text += ("The profile likelihood drops the linearisation: its interval is around the "
                 "likelihood's own estimate (Gaussian noise, σ per group as above), which "
                 "differs from the best run where the objective is not that likelihood."
                 if ident.profile is not None
                 else escape(ident.profile_note) + ".")
        headers, rows = ident.rows()
        out.append((text, headers, rows))
    if r.comparisons:
        names = list(dict.fromkeys(k for c in r.comparisons for k in c["metrics"]))
        headers = ["comparison (not a run, not a truth)", "objective", *names, "note"]
        rows = [[escape(c["name"]), c["f"], *[c["metrics"].get(k) for k in names],
                 escape(c["note"])] for c in r.comparisons]
        out.append(("Fixed rows the problem gives for comparison (a published estimate, a "
                    "predictor a model must beat): never a truth.", headers, rows))
    return out


def _objective(ident: Any) -> str:
    """The best run's objective with the unit and meaning the problem states."""
    unit, what = ident.objective_unit, ident.objective_what
    return (fmt(ident.f, 4) + (f" {escape(unit)}" if unit else "")
            + (f", {escape(what)}" if what else ""))


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
    """What every renderer shows below a context's ranking, as ``(Markdown text, headers,
    rows)`` (empty headers: text only): why row 1 is not the verdict's choice, what the
    answer assumes (:mod:`.assumed`), without a truth the identified values and comparison
    rows, and the fit diagnostics (:mod:`.diagnostics`)."""
    return (_row_one_note(r) + list(r.assumed) + ([] if r.truth else _no_truth_lines(r))
            + diagnostics.blocks(r.diagnostics, r.model_error))


def _row_one_note(r: ContextResult) -> list[tuple[str, list[str], list[list[Any]]]]:
    """Why row 1 of the ranking is not the verdict's choice, when it is not."""
    v = r.decision
    first = r.rows[0][r.headers.index("optimizer")] if r.rows and "optimizer" in r.headers \
        else None
    if v is None or v.kind != verdicts.USE or first is None or first == v.pick:
        return []
    if first in v.references:
        why = "it is a reference (random search or the box centre), never recommended"
    elif v.tied and first in v.tied:
        why = ("the tests do not separate the two by the metric, and the verdict goes by "
               "search quality, then cost")
    else:
        why = "it is not shown to beat every reference that was run"
    # no record text here: the terminal wraps these blocks without keeping names whole
    return [(f"Row 1 of the ranking is not the verdict's choice: {why}.", [], [])]


#: Joins the words of a name while the terminal's verdict is wrapped (never in the output).
_GLUE = "\u00a0"


def _wrap(text: str, width: int) -> str:
    """Markdown prose for the terminal: as a reader sees it (:func:`.safe.shown`), wrapped."""
    return textwrap.fill(clean(shown(" ".join(text.split()))), width=width,
                         break_long_words=False, break_on_hyphens=False)


def _wrap_glued(marked: str, width: int) -> str:
    """A marked verdict wrapped at ``width`` without breaking inside a marked name."""
    glued = re.sub(r"[ \t\n]+", " ", shown(_unmarked(marked, _GLUE)))
    lines = textwrap.wrap(glued, width=width, break_long_words=False, break_on_hyphens=False)
    return clean("\n".join(lines).replace(_GLUE, " "), keep_newlines=True)


def _item(text: str, width: int) -> str:
    """A list item wrapped at ``width``, later lines indented ("8 %" kept on one line)."""
    return textwrap.fill(" ".join(text.split()).replace(" %", _GLUE + "%"), width=width,
                         subsequent_indent="  ", break_long_words=False,
                         break_on_hyphens=False).replace(_GLUE, " ")


def answer_markdown(a: Any) -> list[str]:
    """The answer block of ``report.md`` (:mod:`.answer`): its sentences, the identified
    values where there is no truth, and the compact table per context."""
    if a is None:
        return []
    lines = ["## The answer", "", *(_item(f"- **{label}**: {text}", PROSE_WIDTH)
                                    for label, text in sentences(a)), ""]
    for _, text, headers, rows in a.identified:
        lines += [para(text), "", markdown(headers, rows), ""]
    if a.rows:
        lines += [markdown(a.headers, a.rows), "",
                  para(table_note(a) + " Each verdict in full, with its reasons and the "
                       "ranking: [Results](#results) below."), ""]
    return lines


def answer_terminal(a: Any, width: int) -> str:
    """The answer block for the terminal: the same, wrapped, without code marks."""
    if a is None:
        return ""
    out = ["The answer", *(clean(_item(f"{label}: {text}".replace("`", ""), width),
                                 keep_newlines=True) for label, text in sentences(a))]
    for _, text, headers, rows in a.identified:
        out += ["", _wrap(text, width), terminal(headers, rows)]
    if a.rows:
        out += ["", terminal(a.headers, a.rows)]
    return "\n".join(out)


def terminal_text(items: Sequence[ContextResult], width: int | None = None,
                  answer: Any = None) -> str:
    """The same first screen for the terminal: the answer (:mod:`.answer`) first, then a
    table and a verdict per context, the prose wrapped to the terminal's width."""
    width = width or max(40, shutil.get_terminal_size((80, 24)).columns)  # 80 if unknown
    blocks = [answer_terminal(answer, width)] if answer is not None else []
    for r in items:
        extra = "".join(_wrap(text, width) + "\n" + (terminal(h, rows) + "\n" if h else "")
                        for text, h, rows in extra_blocks(r))
        verdict = (_wrap(r.verdict, width) if r.decision is None else
                   _wrap_glued(_marked_verdict(r.decision), width))
        blocks.append(f"{clean(r.context)}\n" + terminal(r.headers, r.rows) + "\n" + extra
                      + verdict)
    return "\n\n".join(blocks)
