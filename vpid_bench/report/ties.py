"""Ties are ties: the ONE rule by which the report calls runs and optimizers equal, and how
it breaks the tie.

* **Runs at the same optimum.** Two ok runs of a context that fit the same data (the same
  instance id; every run where the instances are identical) and whose objective values differ
  by at most :data:`OBJECTIVE_RTOL` relative (the archive's final target, 1e-8) ended at the
  same optimum: their differences in any metric are floating-point noise. :func:`snap_ties`
  gives each such run the metric values of the lowest run among them, before any test,
  ranking or verdict reads the runs, so the pairwise tests see zero differences (no pair at
  the same optimum is "significantly different") and medians are equal, truth and no-truth
  alike.
* **Optimizers with equal medians.** Optimizers of a context whose median metrics differ by
  at most :data:`OBJECTIVE_RTOL` relative share a rank (shown ``1=``), ordered by search
  cost: the fewest evaluations to each instance's optimum (ERT at the final target), then
  the fewest seconds, costs within :data:`COST_TIE` of each other counting as equal
  (:func:`cheapest`); the verdict breaks its ties by the same function.
* **Optimizers at a budget.** At one rung of the budget ladder (the share of (run, target)
  pairs solved by 10·D, 100·D, ... evaluations, :mod:`.suite_scores`), optimizers whose
  shares lie within :data:`SHARE_TIE` of the highest solve as many: the report's answer
  (:mod:`.answer`) names them together, the one with the higher suite score (the mean area
  under its ECDF: it gets there sooner) first (:func:`share_leaders`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

#: Objective values within this relative difference are the same optimum (the archive's
#: final target, :data:`vpid_bench.targets`).
OBJECTIVE_RTOL = 1e-8
#: Two costs (evaluations or seconds to the optimum) within this relative difference tie.
COST_TIE = 0.10
#: Two medians within this relative distance are not called different in words (a
#: disagreement between the two rankings, a floor undercut): a looser tolerance than
#: :data:`OBJECTIVE_RTOL`, for sentences only, never for a rank, a test or a pick.
WORDS_RTOL = 1e-3

#: Shares solved (0 to 1) within this absolute difference tie: one percentage point, about
#: two standard errors of a share near 98 % over the 1,785 (run, target) pairs of a suite of
#: 17 problems x 15 runs x 7 targets, and the precision the report prints shares at.
SHARE_TIE = 0.01

T = TypeVar("T")


def same(a: float, b: float, rtol: float = OBJECTIVE_RTOL) -> bool:
    """Whether ``a`` and ``b`` are equal within ``rtol`` relative (non-finite: only equal
    values)."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return a == b
    return abs(a - b) <= rtol * max(abs(a), abs(b), 1e-300)


def _instance_key(record: Mapping[str, Any]) -> Any:
    """The data a run fitted: its instance id (``None``: all instances identical)."""
    inst = record.get("instance")
    iid = inst.get("id") if isinstance(inst, Mapping) else None
    return iid if isinstance(iid, str) else None


def snap_ties(rows: list[dict[str, Any]], records: Sequence[Mapping[str, Any]]) -> int:
    """In place: per context and instance, the ok runs whose ``f_best`` lies within
    :data:`OBJECTIVE_RTOL` of the lowest there take that lowest run's ``metric`` and
    ``metric.<name>`` values (see the module). Returns how many runs changed."""
    by_id = {r["run_id"]: r for r in records}
    groups: dict[tuple[str, Any], list[dict[str, Any]]] = {}
    for row in rows:
        f = row.get("f_best")
        if row["status"] == "ok" and isinstance(f, (int, float)) and math.isfinite(f):
            key = (row["context"], _instance_key(by_id.get(row["run_id"], {})))
            groups.setdefault(key, []).append(row)
    changed = 0
    for g in groups.values():
        best = min(g, key=lambda r: float(r["f_best"]))
        names = [k for k in best if k == "metric" or k.startswith("metric.")]
        for row in g:
            if row is best or not same(float(row["f_best"]), float(best["f_best"])):
                continue
            changed += any(row.get(k) != best[k] for k in names)
            for k in names:
                row[k] = best[k]
    return changed


def cheapest(items: Sequence[T], cost: Callable[[T], tuple[float, float]]
             ) -> tuple[T, str]:
    """The cheapest of ``items`` to reach the optimum, ``cost(item) = (evaluations,
    seconds)``: fewest evaluations, then fewest seconds, a difference within
    :data:`COST_TIE` counting as none; returns ``(item, "evaluations" | "seconds")``, or
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
    """``items`` cheapest first by :func:`cheapest` (the order of ``items`` where cost does
    not decide)."""
    rest, out = list(items), []
    while rest:
        pick, _ = cheapest(rest, cost)
        out.append(pick)
        rest.remove(pick)
    return out


def rank_with_ties(summary: list[dict[str, Any]],
                   costs: Mapping[tuple[str, str], tuple[float, float]]) -> None:
    """In place: per context, the rows with runs ordered by median metric, optimizers whose
    medians are :func:`same` tied and ordered by :func:`by_cost` (``costs[(context,
    algorithm)] = (evaluations, seconds)`` to the optimum); ``rank`` is each row's place
    (1, 2, ...), ``rank_tied`` the tie's first place and ``rank_shown`` its text (``"1="``
    for a tie of more than one). The list is reordered to match."""
    by_context: dict[str, list[dict[str, Any]]] = {}
    for s in summary:
        by_context.setdefault(s["context"], []).append(s)
    out: list[dict[str, Any]] = []
    for context in sorted(by_context):
        g = by_context[context]
        ranked = sorted((s for s in g if s.get("n_runs")), key=lambda s: s["rank"])
        place = 1
        while ranked:
            head = ranked[0]
            tie = [s for s in ranked if same(float(s.get("median", math.nan)),
                                             float(head.get("median", math.nan)))]
            for s in tie:
                ranked.remove(s)
            ordered = by_cost(tie, lambda s, c=context: costs.get((c, s["algorithm"]),
                                                                   (math.inf, math.nan)))
            for i, s in enumerate(ordered):
                s["rank"], s["rank_tied"] = place + i, place
                s["rank_shown"] = f"{place}=" if len(ordered) > 1 else str(place)
                out.append(s)
            place += len(ordered)
        out += [s for s in g if not s.get("n_runs")]
    summary[:] = out


def share_leaders(shares: Mapping[str, float], scores: Mapping[str, float]
                  ) -> tuple[str, ...]:
    """The optimizers whose share (finite, 0 to 1) lies within :data:`SHARE_TIE` of the
    highest of ``shares``: the leader at that budget and those that solve as many, highest
    ``scores`` first (then by name); empty when no share is finite."""
    finite = {k: v for k, v in shares.items() if math.isfinite(v)}
    if not finite:
        return ()
    top = max(finite.values())
    tied = [k for k, v in finite.items() if v >= top - SHARE_TIE]
    return tuple(sorted(tied, key=lambda k: (-scores.get(k, -math.inf), -finite[k], k)))
