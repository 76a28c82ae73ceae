"""Anytime performance against each instance's optimum (numpy only). A *target* is a
relative gap to the optimum (1, 0.1, ..., 1e-6), *hit* at the end of the first batch whose
best-so-far reaches it. The fixed-target ECDF is the share of (run, target) pairs hit within
``e`` evaluations; the ERT of a target, the evaluations all runs spent until they hit it (a
run that never does: its whole use) over the runs that hit it (``inf``: none); the AUC, the
area under the ECDF over ``log(e)`` from 1 to the budget ``B`` over ``log(B)`` (1: every
target at the first evaluation)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import figures
from .load import grouped
from .optima import rel_gap
from .styles import legend, lookup

#: The fixed targets on the relative gap to the instance's optimum.
TARGETS: tuple[float, ...] = tuple(10.0 ** -k for k in range(7))


@dataclasses.dataclass(frozen=True)
class RunHits:
    """When one run hit each target: evaluations (``nan`` = never), and what it used."""

    context: str
    algorithm: str
    budget: float
    used: float
    hits: tuple[float, ...]
    #: per target, the batches (rounds of ask/tell) and the run's seconds until the hit
    #: (``nan``: never, or no per-batch times); and what the whole run used of each
    hit_batches: tuple[float, ...] = ()
    hit_seconds: tuple[float, ...] = ()
    used_batches: float = math.nan
    used_seconds: float = math.nan


def hit_times(evaluations: Sequence[float], gaps: Sequence[float],
              targets: Sequence[float] = TARGETS) -> tuple[float, ...]:
    """The first evaluation count (or any cost aligned with the trace) at which ``gaps`` is
    at most each target; ``nan`` where never."""
    ev, g = np.asarray(evaluations, float), np.asarray(gaps, float)
    hit = [np.flatnonzero(np.isfinite(g) & (g <= t)) for t in targets]
    return tuple(float(ev[i[0]]) if i.size else math.nan for i in hit)


def run_hits(records: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]],
             targets: Sequence[float] = TARGETS) -> list[RunHits]:
    """:class:`RunHits` of every successful run whose instance's optimum is known."""
    by_id = {r["run_id"]: r for r in records}
    out = []
    for row in rows:
        f_opt = row.get("f_opt", math.nan)
        if row["status"] != "ok" or not math.isfinite(float(f_opt)):
            continue
        trace = by_id[row["run_id"]].get("trace") or {}
        ev, best = trace.get("evaluations") or [], trace.get("best") or []
        if not ev or len(ev) != len(best):
            continue
        gaps = [rel_gap(float(b) - f_opt, f_opt) if b is not None else math.inf for b in best]
        used = float(row["evaluations"]) if math.isfinite(float(row["evaluations"])) \
            else float(ev[-1])
        budget = float(row["budget"]) if row.get("budget") else used
        secs = (by_id[row["run_id"]].get("timing") or {}).get("trace_s") or []
        secs = secs if isinstance(secs, list) and len(secs) == len(ev) else [math.nan] * len(ev)
        secs = [float(v) if isinstance(v, (int, float)) else math.nan for v in secs]
        index = trace.get("batch")  # each entry's batch (an archive's cut trace holds its own)
        index = ([float(b) for b in index] if isinstance(index, list) and len(index) == len(ev)
                 else [float(i) for i in range(1, len(ev) + 1)])
        out.append(RunHits(row["context"], row["algorithm"], max(budget, used), used,
                           hit_times(ev, gaps, targets), hit_times(index, gaps, targets),
                           hit_times(secs, gaps, targets), float(index[-1]),
                           float(row.get("run_time_s", math.nan))))
    return out


def ecdf(runs: Sequence[RunHits], grid: Sequence[float]) -> np.ndarray:
    """The share of (run, target) pairs hit within each number of evaluations of ``grid``."""
    h = np.asarray([r.hits for r in runs], float).ravel()
    grid = np.asarray(grid, float)
    if not h.size:
        return np.zeros(grid.shape)
    hit = np.where(np.isfinite(h), h, np.inf)
    return (hit[None, :] <= grid[:, None]).mean(axis=1)


def ert(runs: Sequence[RunHits], target_index: int, cost: str = "evaluations") -> float:
    """Expected running time of one target in ``evaluations``, ``batches`` (what parallel
    hardware cannot shorten) or ``seconds`` (``nan`` without per-batch times)."""
    hit_of, used_of = {"evaluations": ("hits", "used"), "batches": ("hit_batches", "used_batches"),
                       "seconds": ("hit_seconds", "used_seconds")}[cost]
    hits = np.asarray([getattr(r, hit_of)[target_index] if getattr(r, hit_of) else math.nan
                       for r in runs], float)
    if cost != "evaluations":
        ok = np.isfinite(np.asarray([r.hits[target_index] for r in runs], float))
        if np.any(ok & ~np.isfinite(hits)):
            return math.nan  # hit, but the record does not say when in this cost
    used = np.asarray([getattr(r, used_of) for r in runs], float)
    n_hit = int(np.isfinite(hits).sum())
    if n_hit == 0:
        return math.inf
    return float(np.where(np.isfinite(hits), hits, used).sum() / n_hit)


def auc(runs: Sequence[RunHits], budget: float | None = None) -> float:
    """Area under the ECDF over log evaluations from 1 to the budget, normalised to [0, 1]."""
    if not runs:
        return math.nan
    b = float(budget if budget is not None else max(r.budget for r in runs))
    h = np.asarray([r.hits for r in runs], float).ravel()
    if b <= 1:
        return float(np.mean(np.isfinite(h) & (h <= b)))
    h = np.where(np.isfinite(h) & (h <= b), np.maximum(h, 1.0), np.nan)
    share = np.where(np.isfinite(h), np.log(b / np.where(np.isfinite(h), h, 1.0)) / np.log(b), 0.0)
    return float(share.mean())


def _groups(runs: Sequence[RunHits]) -> dict[tuple[str, str], list[RunHits]]:
    return grouped(runs, lambda r: (r.context, r.algorithm))


def context_budget(runs: Sequence[RunHits], context: str) -> float:
    """The largest budget of a context's runs (the common x range of its ECDF and AUC)."""
    return max(r.budget for r in runs if r.context == context)


def auc_table(runs: Sequence[RunHits]) -> dict[tuple[str, str], float]:
    """AUC per (context, algorithm), over the context's budget."""
    return {k: auc(g, context_budget(runs, k[0])) for k, g in _groups(runs).items()}


def ert_rows(runs: Sequence[RunHits], targets: Sequence[float] = TARGETS) -> list[list[Any]]:
    """Rows (context, algorithm, target, runs, hits, ert) for ``tables/ert.csv``."""
    rows = []
    for (context, algorithm), g in sorted(_groups(runs).items()):
        for i, t in enumerate(targets):
            n_hit = sum(math.isfinite(r.hits[i]) for r in g)
            rows.append([context, algorithm, t, len(g), n_hit, ert(g, i),
                         ert(g, i, "batches"), ert(g, i, "seconds")])
    return rows


ERT_HEADERS = ["context", "algorithm", "target_rel_gap", "runs", "hits", "ert",
               "ert_batches", "ert_seconds"]


def ecdf_figure(runs: Sequence[RunHits], context: str, path: Path,
                style_of: Mapping[str, Any] | None = None) -> Path | str:
    """The fixed-target ECDF of one context: a step line per optimizer in its report style."""
    sel = [r for r in runs if r.context == context]
    if not sel:
        return f"no run of {context} knows its instance's optimum"
    b = context_budget(runs, context)
    grid = np.unique(np.round(np.geomspace(1.0, max(b, 2.0), 300)))
    fig, ax = figures._plt().subplots(figsize=(7.0, 4.4))
    groups = sorted(_groups(sel).items())
    look = lookup(style_of, [a for (_, a), _ in groups])
    for (_, algorithm), g in groups:
        ax.step(grid, ecdf(g, grid), where="post", **look[algorithm].mpl(),
                label=f"{algorithm} (AUC {auc(g, b):.2f}, {len(g)} runs)")
    ax.set_xscale("log")
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlim(1, max(b, 2.0))
    ax.set_xlabel("objective evaluations (log scale)")
    ax.set_ylabel("share of (run, target) pairs reached")
    ax.set_title(f"{context}: fixed-target ECDF, targets rel_gap = 1, 0.1, ..., 1e-6\n"
                 "(relative gap to each instance's optimum; a batch's hit counts at its end)",
                 fontsize=9)
    legend(ax, len(groups))
    ax.grid(True, which="major", alpha=0.3)
    return figures.save(fig, path)


def costs_to_optimum(hits: Sequence[Any]) -> dict[tuple[str, str], tuple[float, float]]:
    """Per (context, algorithm): the ERT to the final target in evaluations and seconds."""
    last = len(TARGETS) - 1
    return {k: (ert(g, last), ert(g, last, "seconds")) for k, g in _groups(hits).items()}
