"""The HTML pages' interactive figures as data (numpy only): each context's fixed-target ECDF
and convergence, the suite's ECDF, one series per optimizer in data units, with axes and an
alt text, drawn inline as SVG (:mod:`.svg`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .anytime import RunHits, _groups, auc, context_budget, ecdf
from .figures import convergence_panels, thin_steps
from .identifiability import reference_levels
from .load import trace_sets
from .suite_scores import _budgets, _by, aggregated_ecdf

#: At most this many points per curve (steps thinned as :func:`.figures.thin_steps` does).
MAX_POINTS = 160
#: ECDF evaluation grid: this many log-spaced evaluation counts from 1 to the budget.
ECDF_GRID = 240


@dataclasses.dataclass(frozen=True)
class Series:
    """One optimizer's step curve through (x, y), with a band ``lo``/``hi`` or none."""

    name: str
    x: tuple[float, ...]
    y: tuple[float, ...]
    lo: tuple[float, ...] = ()
    hi: tuple[float, ...] = ()
    label: str = ""  # the legend's text (defaults to the name)


@dataclasses.dataclass(frozen=True)
class Figure:
    """An interactive figure; ``lines``: horizontal reference lines (label, y)."""

    key: str
    title: str
    alt: str
    x_label: str
    y_label: str
    x_log: bool
    y_log: bool
    series: tuple[Series, ...]
    lines: tuple[tuple[str, float], ...] = ()
    y_range: tuple[float, float] | None = None


def _tuple(a: Any) -> tuple[float, ...]:
    return tuple(float(v) for v in np.asarray(a, float))


def ecdf_figure(hits: Sequence[RunHits], context: str) -> Figure | None:
    """The fixed-target ECDF of ``context`` (``None``: no run knows its optimum)."""
    sel = [h for h in hits if h.context == context]
    if not sel:
        return None
    budget = context_budget(hits, context)
    grid = np.unique(np.round(np.geomspace(1.0, max(budget, 2.0), ECDF_GRID)))
    series = []
    for (_, name), g in sorted(_groups(sel).items()):
        x, y = thin_steps(grid, ecdf(g, grid), max_points=MAX_POINTS)
        series.append(Series(name, _tuple(x), _tuple(y),
                             label=f"{name} (AUC {auc(g, budget):.2f}, {len(g)} runs)"))
    alt = (f"Fixed-target ECDF of {context}: for each of {len(series)} optimizers, the share "
           "of (run, target) pairs reached (targets: relative gap to each instance's optimum "
           f"1, 0.1, ..., 1e-6) against objective evaluations, 1 to {budget:,.0f}, log scale.")
    return Figure(f"ecdf:{context}", f"Fixed-target ECDF, {context}", alt,
                  "objective evaluations (log scale)", "share of (run, target) pairs reached",
                  True, False, tuple(series), y_range=(0.0, 1.0))


def convergence_figure(panel: Mapping[str, Any]) -> Figure:
    """One context's convergence (a panel of :func:`.figures.convergence_panels`)."""
    context = str(panel["context"])
    values = [np.asarray(panel["values"], float)]
    series = [Series(str(c["algorithm"]), *map(_tuple, thin_steps(  # x, median and the IQR
        c["x"], c["median"], c["q25"], c["q75"], max_points=MAX_POINTS))) for c in panel["curves"]]
    lines = []
    for label, key in (("f at the true parameters (median over instances)", "f_true"),
                       ("record optimum f* (median over instances)", "f_opt")):
        v = panel.get(key)
        if v is not None and math.isfinite(v):
            lines.append((label, float(v)))
            values.append(np.array([v]))
    every = np.concatenate(values)
    finite = every[np.isfinite(every)]
    y_log = bool(finite.size and np.all(finite > 0))
    runs = ", ".join(map(str, panel.get("runs", [])))
    alt = (f"Convergence on {context}: the median over the runs (runs per optimizer: {runs}) "
           f"of the best objective value found so far, against objective evaluations, for "
           f"{len(series)} optimizers, with the interquartile range as a band"
           + (" and dashed reference lines" if lines else "") + ".")
    return Figure(f"convergence:{context}", f"Convergence, {context}", alt,
                  "objective evaluations used",
                  "best objective value so far" + (" (log scale)" if y_log else ""),
                  False, y_log, tuple(series), tuple(lines))


def convergence_figures(records: Sequence[Mapping[str, Any]],
                        rows: Sequence[Mapping[str, Any]]) -> dict[str, Figure]:
    """Per context, its convergence figure (contexts without a finite trace left out)."""
    traces = trace_sets(list(records), list(rows))
    if not traces:
        return {}
    panels = convergence_panels(traces, *reference_levels(records, rows))
    return {str(p["context"]): convergence_figure(p) for p in panels}


def suite_ecdf_figure(runs: Sequence[RunHits], facts: Mapping[str, tuple[str, int]]
                      ) -> Figure | None:
    """The runtime ECDF aggregated over the suite (:func:`.suite_scores.aggregated_ecdf`),
    one series per optimizer that ran every problem; ``None`` below two problems."""
    budgets, by_alg = _budgets(runs), _by(runs)
    contexts = sorted(c for c in budgets if c in facts)
    if len(contexts) < 2:
        return None
    dims = {c: facts[c][1] for c in contexts}
    top = max(budgets[c] / max(dims[c], 1) for c in contexts)
    grid = np.geomspace(min(1.0 / max(max(dims.values()), 1), 0.1), max(top, 1.0), ECDF_GRID)
    series = []
    for name, per in sorted(by_alg.items()):
        if all(c in per for c in contexts):
            x, y = thin_steps(grid, aggregated_ecdf({c: per[c] for c in contexts}, dims, grid),
                              max_points=MAX_POINTS)
            series.append(Series(name, _tuple(x), _tuple(y)))
    alt = (f"Runtime ECDF aggregated over the {len(contexts)} problems, each weighing the "
           f"same: for each of {len(series)} optimizers, the share of (run, target) pairs "
           "reached (relative gap to each instance's optimum 1, 0.1, ..., 1e-6) against "
           "objective evaluations per parameter, log scale.")
    return Figure("ecdf:suite", "Runtime ECDF across the suite", alt,
                  "objective evaluations / D (log scale)",
                  "share of (run, target) pairs reached", True, False, tuple(series),
                  y_range=(0.0, 1.0))
