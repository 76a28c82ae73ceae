"""Ties are ties: the ONE rule by which the report calls runs and optimizers equal, and how
it breaks the tie:

* Runs of one instance whose objectives lie within :data:`OBJECTIVE_RTOL` ended at the same
  optimum: :func:`snap_ties` gives them the lowest one's metrics before any test, ranking or
  verdict reads them (their differences are floating-point noise).
* Optimizers whose median metrics lie within :data:`OBJECTIVE_RTOL` share a rank (``1=``),
  ordered by cost to the optimum (:func:`cheapest`: ERT, then seconds, within
  :data:`COST_TIE`); the verdict breaks its ties the same way.
* At a rung of the budget ladder, shares within :data:`SHARE_TIE` of the highest solve as
  many (:func:`share_leaders`), the higher suite score first."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

from ..store.archive_records import instance_id
from ..store.job_checks import finite
from .load import by_context, grouped

#: Objective values within this relative difference are the same optimum (the archive's
#: final target, :data:`vpid_bench.targets`).
OBJECTIVE_RTOL = 1e-8
#: Two costs (evaluations or seconds to the optimum) within this relative difference tie.
COST_TIE = 0.10
#: Two medians within this relative distance are not called different in words (never used
#: for a rank, a test or a pick).
WORDS_RTOL = 1e-3

#: Shares solved (0 to 1) within this absolute difference tie: one percentage point, about
#: two standard errors of a share near 98 % over a suite's 1,785 (run, target) pairs.
SHARE_TIE = 0.01

T = TypeVar("T")


def same(a: float, b: float, rtol: float = OBJECTIVE_RTOL) -> bool:
    """Whether ``a`` and ``b`` are equal within ``rtol`` relative (non-finite: only if equal)."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return a == b
    return abs(a - b) <= rtol * max(abs(a), abs(b), 1e-300)


def snap_ties(rows: list[dict[str, Any]], records: Sequence[Mapping[str, Any]]) -> int:
    """In place: per context and instance, the ok runs within :data:`OBJECTIVE_RTOL` of the
    lowest take its metric values. Returns how many runs changed."""
    by_id = {r["run_id"]: r for r in records}
    groups = grouped((row for row in rows if row["status"] == "ok" and finite(row.get("f_best"))),
                     lambda row: (row["context"], instance_id(by_id.get(row["run_id"], {}))))
    changed = 0
    for g in groups.values():
        best = min(g, key=lambda r: float(r["f_best"]))
        names = [k for k in best if k == "metric" or k.startswith("metric.")]
        for row in g:
            if row is best or not same(float(row["f_best"]), float(best["f_best"])):
                continue
            changed += any(row.get(k) != best[k] for k in names)
            row.update({k: best[k] for k in names})
    return changed


def cheapest(items: Sequence[T], cost: Callable[[T], tuple[float, float]]) -> tuple[T, str]:
    """The cheapest of ``items`` to reach the optimum (``cost(item) = (evaluations,
    seconds)``, within :data:`COST_TIE` a tie): ``(item, "evaluations" | "seconds")``, or
    ``(items[0], "")`` when cost does not decide."""
    pool = list(items)
    for i, key in enumerate(("evaluations", "seconds")):
        values = [cost(m)[i] for m in pool]
        finite = [v for v in values if math.isfinite(v)]
        if not finite:
            break
        low = min(finite)
        pool = [m for m, v in zip(pool, values, strict=True)
                if math.isfinite(v) and v <= low * (1 + COST_TIE)]
        if len(pool) == 1:
            return pool[0], key
    return pool[0], ""


def by_cost(items: Sequence[T], cost: Callable[[T], tuple[float, float]]) -> list[T]:
    """``items`` cheapest first by :func:`cheapest` (in their order where cost does not decide)."""
    rest, out = list(items), []
    while rest:
        pick, _ = cheapest(rest, cost)
        out.append(pick)
        rest.remove(pick)
    return out


def rank_with_ties(summary: list[dict[str, Any]],
                   costs: Mapping[tuple[str, str], tuple[float, float]]) -> None:
    """In place: per context, the rows ordered by median metric, :func:`same` medians by
    :func:`by_cost` (``costs[(context, algorithm)]``); ``rank`` is each row's place,
    ``rank_tied`` its tie's first and ``rank_shown`` its text (``"1="``)."""
    grouped = by_context(summary)
    out: list[dict[str, Any]] = []
    for context in sorted(grouped):
        g = grouped[context]
        ranked = sorted((s for s in g if s.get("n_runs")), key=lambda s: s["rank"])
        place = 1
        while ranked:
            head = ranked[0]
            tie = [s for s in ranked if same(float(s.get("median", math.nan)),
                                             float(head.get("median", math.nan)))]
            ranked = [s for s in ranked if s not in tie]
            ordered = by_cost(tie, lambda s, c=context: costs.get((c, s["algorithm"]),
                                                                   (math.inf, math.nan)))
            for i, s in enumerate(ordered):
                s["rank"], s["rank_tied"] = place + i, place
                s["rank_shown"] = f"{place}=" if len(ordered) > 1 else str(place)
                out.append(s)
            place += len(ordered)
        out += [s for s in g if not s.get("n_runs")]
    summary[:] = out


def share_leaders(shares: Mapping[str, float], scores: Mapping[str, float]) -> tuple[str, ...]:
    """The optimizers whose share lies within :data:`SHARE_TIE` of the highest, highest
    ``scores`` first (then by name); empty when no share is finite."""
    finite = {k: v for k, v in shares.items() if math.isfinite(v)}
    if not finite:
        return ()
    top = max(finite.values())
    tied = [k for k, v in finite.items() if v >= top - SHARE_TIE]
    return tuple(sorted(tied, key=lambda k: (-scores.get(k, -math.inf), -finite[k], k)))
