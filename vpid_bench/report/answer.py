"""The answer first, at the top of the terminal, ``report.md`` and the HTML overview, all
derived from what the report computed: which optimizer leads at each rung of the budget
ladder (:mod:`.suite_scores`; given with and without residuals where optimizers that use
them lead; references never named a leader), whom the verdicts recommend per problem, which
estimator and where it limits the accuracy, a compact table per context, and without a truth
the identified values. Texts are Markdown with record text escaped."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from typing import Any

from ..store.job_checks import finite
from . import verdicts
from .render import fmt, joined
from .safe import escape
from .suite_scores import LADDER
from .ties import SHARE_TIE, share_leaders

#: What limits the leader (:data:`.verdicts.LIMIT_SEARCH` ...), in a few words.
LIMITS = {"search": "more search would still gain",
          "below_floor": "its runs stopped short of the optimum (below the floor)",
          "estimator": "the estimator (objective) sets the floor",
          "model": "model error sets the floor",
          "records": "the records set the floor: more search will not help",
          "truth": "the records allow the truth itself: only search limits it"}
#: The same in the answer's table, in fewer words.
LIMITED_BY = {"search": "search (more would gain)", "below_floor": "search (runs stop short)",
              "estimator": "the estimator", "model": "model error", "records": "the records",
              "truth": "search (to the truth)"}
#: Without a truth: whether the leader reaches the record's optimum.
LIMITS_NO_TRUTH = {True: "the record (optimum reached)", False: "search (more would move it)"}


@dataclasses.dataclass(frozen=True)
class Rung:
    """Who leads at ``per_dim`` evaluations per parameter: the leader first, then those that
    solve as many; ``share``: the leader's share of (run, target) pairs solved;
    ``references``: references that solve as many."""

    per_dim: int
    leaders: tuple[str, ...]
    share: float
    references: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class Pool:
    """The leaders among some optimizers, rung by rung (``label``: ``"with residuals"``,
    ``"without residuals"`` or ``""``)."""

    label: str
    rungs: tuple[Rung, ...]


@dataclasses.dataclass
class Answer:
    """The answer of a report, as data (see the module)."""

    pools: tuple[Pool, ...] = ()
    problems: int = 0  # problems scored across the suite (0: no suite scores)
    contexts: int = 0
    per_problem: bool = True  # one context per problem: say "problems", not "contexts"
    picks: dict[str, int] = dataclasses.field(default_factory=dict)  # verdicts' picks
    unrecommended: int = 0  # contexts with no recommendation
    described: int = 0  # contexts where nothing was compared
    budget: str = ""  # the runs' budget, "1,000·D" where every context shares one per D
    estimators: dict[str, int] = dataclasses.field(default_factory=dict)
    #: (context, advice) where the estimator sets the floor (:class:`.verdicts.EstimatorAdvice`)
    bottleneck: list[tuple[str, Any, str]] = dataclasses.field(default_factory=list)
    truth: bool = True  # False: no context has a truth
    headers: list[str] = dataclasses.field(default_factory=list)
    rows: list[list[Any]] = dataclasses.field(default_factory=list)
    #: per context without a truth: (context, text, headers, rows) of its identified values
    identified: list[tuple[str, str, list[str], list[list[Any]]]] = dataclasses.field(
        default_factory=list)


def _share(v: float) -> str:
    return f"{100 * v:.0f} %"


#: A list of tied optimizers longer than this names its first three and counts the rest.
MAX_NAMED = 4


def _names(items: Sequence[str]) -> str:
    """```a`, `b` and `c```, or ```a`, `b`, `c` and 9 more`` past :data:`MAX_NAMED`."""
    shown = [f"`{escape(i)}`" for i in items]
    if len(shown) > MAX_NAMED:
        shown = [*shown[:MAX_NAMED - 1], f"{len(shown) - MAX_NAMED + 1} more"]
    return joined(shown)


def _rung(per_dim: int) -> str:
    return f"{per_dim:,}·D"


def leaders(ladder: Sequence[Sequence[Any]], scores: Mapping[str, float],
            pool: set[str], references: Sequence[str]) -> tuple[Rung, ...]:
    """Per rung of the ladder that some run reached: the leaders among ``pool`` (ladder rows
    ``[group, algorithm, share at 10·D, ...]``, :func:`.suite_scores.ladder_rows`)."""
    out = []
    for k, per_dim in enumerate(LADDER):
        shares = {r[1]: float(r[2 + k]) for r in ladder}
        lead = share_leaders({a: v for a, v in shares.items() if a in pool}, scores)
        if not lead:
            continue
        top = shares[lead[0]]
        refs = tuple(r for r in references if r in shares and r not in pool
                     and math.isfinite(shares[r]) and shares[r] >= top - SHARE_TIE)
        out.append(Rung(per_dim, lead, top, refs))
    return tuple(out)


def pools(ladder: Sequence[Sequence[Any]], scores: Mapping[str, float],
          residual_users: set[str] | frozenset[str],
          references: Sequence[str] = verdicts.REFERENCES) -> tuple[Pool, ...]:
    """The leaders rung by rung: once among every optimizer, and where optimizers that use
    residuals lead somewhere, once more among those that do not."""
    every = {r[1] for r in ladder} - set(references)
    if not every:
        return ()
    black_box = every - set(residual_users)
    with_all = leaders(ladder, scores, every, references)
    if not black_box or black_box == every:
        return (Pool("", with_all),)
    without = leaders(ladder, scores, black_box, references)
    if [r.leaders[0] for r in with_all] == [r.leaders[0] for r in without]:
        return (Pool("", with_all),)
    return (Pool("with residuals", with_all), Pool("without residuals", without))


def _pool_text(pool: Pool) -> str:
    """``"`nevergrad` by 10·D and 100·D (8 %, 56 %), `cmaes` by 1,000·D (98 %; `de2` as
    many)"``: consecutive rungs with one leader said once."""
    spans = [list(g) for _, g in itertools.groupby(pool.rungs, key=lambda r: r.leaders[0])]
    parts = []
    for span in spans:
        if len(spans) == 1 and len(span) > 1:
            head = "at every budget"
            shares = ", ".join(f"{_rung(r.per_dim)}: {_share(r.share)}" for r in span)
        else:
            head = "by " + " and ".join(_rung(r.per_dim) for r in span)
            shares = ", ".join(_share(r.share) for r in span)
        extra = []
        for r in span:
            at = f" by {_rung(r.per_dim)}" if len(span) > 1 else ""
            if r.leaders[1:]:
                extra.append(f"{_names(r.leaders[1:])} as many{at}")
            if r.references:
                refs = " and ".join(verdicts.REFERENCE_WORDS.get(x, escape(x))
                                    for x in r.references)
                extra.append(f"{refs} as many{at}: none is shown to beat it there")
        parts.append(f"`{escape(span[0].leaders[0])}` {head} ({shares}"
                     + "".join(f"; {e}" for e in extra) + ")")
    return ", ".join(parts)


def _count(items: Mapping[str, int], total: int, noun: str) -> str:
    """``"`lsq` on all 17 problems"``, ``"`lsq` on 9 and `cmaes` on 2 of 17 problems"``."""
    ordered = sorted(items.items(), key=lambda kv: (-kv[1], kv[0]))
    if len(ordered) == 1 and ordered[0][1] == total:
        every = {1: "the one", 2: "both"}.get(total, f"all {total}")
        return f"`{escape(ordered[0][0])}` on {every} {noun[:-1] if total == 1 else noun}"
    body = joined([f"`{escape(k)}` on {v}" for k, v in ordered])
    return f"{body} of {total} {noun[:-1] if total == 1 else noun}"


def sentences(a: Answer) -> list[tuple[str, str]]:
    """The answer as (label, Markdown sentence) pairs, in order."""
    out: list[tuple[str, str]] = []
    noun = "problems" if a.per_problem else "contexts"
    if a.pools:
        text = "; ".join((f"{p.label}, " if p.label else "") + _pool_text(p)
                         for p in a.pools if p.rungs)
        out.append(("Which optimizer, by budget",
                    f"{text}. Share of (run, target) pairs solved across the {a.problems} "
                    "problems, each weighing the same (the budget ladder below)."))
    if a.contexts:
        parts = []
        if a.picks:
            parts.append("use " + _count(a.picks, a.contexts, noun))
        if a.unrecommended:
            on = ("" if a.contexts == 1 else " on any" if a.unrecommended == a.contexts
                  else f" on {a.unrecommended}")
            parts.append(f"no method is recommended{on}")
        if a.described:
            on = "" if a.described == a.contexts else f" on {a.described}"
            parts.append(f"nothing was compared{on} (a description, not a recommendation)")
        at = f" at the runs' budget ({a.budget})" if a.budget else ""
        if parts:
            out.append(("Per problem", f"the verdicts{at}: " + "; ".join(parts) + "."))
    if a.estimators:
        text = "the objective " + _count(a.estimators, a.contexts, noun)
        if a.bottleneck:
            bits = []
            for context, adv, unit in a.bottleneck[:3]:
                bit = (f"{escape(context)} (its optimum's error {fmt(adv.ratio, 2)}× the "
                       "Cramér–Rao bound")
                if adv.better is not None:
                    bit += (f"; problem.objective={escape(adv.better)}'s optimum lies "
                            f"{fmt(adv.better_floor, 3)} {escape(unit)} from the truth against "
                            f"{fmt(adv.chosen_floor, 3)} {escape(unit)} on the first "
                            f"{adv.instances} instance(s)")
                bits.append(bit + ")")
            more = len(a.bottleneck) - len(bits)
            text += (f"; it limits the accuracy on {len(a.bottleneck)}: " + "; ".join(bits)
                     + (f"; and {more} more (the table)" if more > 0 else ""))
        elif a.truth:
            text += "; it does not limit the accuracy on any of them (the records or the " \
                    "search do)"
        out.append(("Estimator", text + "."))
    return out


def _words(v: Any) -> str:
    """A verdict (:class:`.verdicts.Verdict`) in a few words (record text raw)."""
    if v is None or v.kind == verdicts.EMPTY:
        return "no successful run"
    if v.kind == verdicts.USE:
        return f"use {v.pick}" + (f" ({len(v.tied)} not separated)" if v.tied else "")
    if v.kind == verdicts.DESCRIBE:
        return f"{v.pick} described (nothing compared)"
    if v.cannot_identify:
        return "none: model error"
    if v.over_bound:
        return f"none: bound over {verdicts.BOUND_LIMIT:g} %"
    return f"none beats {' or '.join(v.not_beaten)}" if v.not_beaten else "none recommended"


def _limit(v: Any) -> str:
    if v is None or v.kind == verdicts.EMPTY:
        return ""
    if not v.truth:
        return "" if v.search is None else LIMITS_NO_TRUTH[v.search.at_optimum]
    return LIMITED_BY.get(v.limit, "")


def table_note(a: Answer) -> str:
    """What the compact table's columns mean (no word of a truth where there is none)."""
    limited = ("limited by: what keeps the verdict's optimizer from doing better (search, "
               "the estimator, model error, the records)")
    if not a.truth:
        return ("Per problem, the verdict in a few words; " + limited.replace(
            "(search, the estimator, model error, the records)",
            "(search, or the record itself once its optimum is reached)") + ".")
    return ("Per problem, the verdict in a few words; floor: the error of each record's own "
            "optimum (median over the instances), below which no search goes; bound: the "
            "Cramér–Rao bound's norm, what an efficient estimator could reach; " + limited + ".")


def _value(x: float, unit: str) -> str:
    return "" if not math.isfinite(x) else (f"{fmt(x, 3)} {unit}".rstrip())


def table(results: Sequence[Any], labels: Mapping[str, str] | None = None
          ) -> tuple[list[str], list[list[Any]]]:
    """The compact table: per context (shown as ``labels[context]``), the verdict in a few
    words, the floor and bound (none without any truth), what limits it; record text raw."""
    truth = any(r.truth for r in results)
    labels = labels or {}
    headers = ["problem", "verdict"] + (["floor", "bound"] if truth else []) + ["limited by"]
    rows = []
    for r in results:
        row = [labels.get(r.context, r.context), _words(r.decision)]
        if truth:
            row += ([_value(r.floor, r.unit), _value(r.bound, r.unit)] if r.truth else ["", ""])
        rows.append([*row, _limit(r.decision)])
    return headers, rows


def _budget(data: Any) -> str:
    """The runs' budget per parameter (``"1,000·D"``) when all share one, else ``""``."""
    dims = {r["run_id"]: len((r.get("parameters") or {}).get("names") or [])
            for r in data.loaded.records}
    per = {round(row["budget"] / d, 6) for row in data.rows
           if finite(row.get("budget")) and (d := dims.get(row["run_id"], 0))}
    v = per.pop() if len(per) == 1 else math.nan
    return f"{v:,.0f}·D" if float(v).is_integer() else ""


def _identified(r: Any) -> tuple[str, str, list[str], list[list[Any]]] | None:
    """The identified values of a context without a truth, with what it assumes."""
    ident = r.identified
    if ident is None:
        return None
    headers, rows = ident.rows()
    text = (f"Identified on {escape(r.context)}: the best run ({escape(ident.run)}), with 95 % "
            "intervals from its residuals")
    text += next((". " + t for t, h, _ in r.assumed if not h and t.startswith("Assumed")), "")
    return r.context, text + ("" if text.endswith(".") else "."), headers, rows


def derive(data: Any, results: Sequence[Any], suite: Any = None,
           residual_users: set[str] | frozenset[str] = frozenset()) -> Answer:
    """The answer of a report from its data, first screens and suite scores (or ``None``);
    ``residual_users``: the optimizers (row labels) that need residuals."""
    a = Answer()
    if suite is not None and suite.ladder:
        scores = {r[2]: float(r[5]) for r in suite.rows if r[0] == "all"}
        a.pools = pools(suite.ladder, scores, residual_users,
                        (*verdicts.REFERENCES, data.baseline))
        a.problems = next((int(r[3]) for r in suite.rows if r[0] == "all"), 0)
    of = {r["context"]: r["problem"] for r in data.rows}
    a.contexts = len(results)
    a.per_problem = len({of.get(r.context) for r in results}) == len(results)
    decisions = [r.decision for r in results]
    a.picks = dict(Counter(v.pick for v in decisions if v is not None
                           and v.kind == verdicts.USE))
    a.unrecommended = sum(v is not None and v.kind == verdicts.NONE for v in decisions)
    a.described = sum(v is not None and v.kind == verdicts.DESCRIBE for v in decisions)
    a.budget = _budget(data)
    a.estimators = dict(Counter(data.estimator(r.context) for r in results
                                if data.estimator(r.context)))
    a.bottleneck = [(r.context, r.decision.advice, r.unit) for r in results
                    if r.decision is not None and r.decision.advice is not None]
    a.truth = any(r.truth for r in results)
    a.headers, a.rows = table(results, {r.context: of.get(r.context, r.context)
                                        for r in results} if a.per_problem else None)
    a.identified = [x for x in (_identified(r) for r in results if not r.truth) if x]
    return a


def residual_users(registry: Any, rows: Sequence[Mapping[str, Any]]) -> frozenset[str]:
    """The optimizers (row labels, ``algorithm``) whose installed class sets
    ``wants_residuals``; one not installed here counts as needing none."""
    classes = getattr(registry, "optimizers", None) or {}
    return frozenset(r["algorithm"] for r in rows
                     if getattr(classes.get(r["optimizer"]), "wants_residuals", False))
