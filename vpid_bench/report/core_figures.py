"""The report's own figures (PNG): convergence, per problem the per-run metric and the error
heatmap, per context the ECDF and critical-difference diagram, and one across blocks. A
figure that cannot be drawn, or raises, leaves a reason instead of a path. Planned here,
drawn side by side in forked processes (half an archive report's time)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..fileio import write_refused
from ..progress import Stages
from . import anytime, figures, stats
from .forked import run_forked
from .identifiability import reference_levels
from .load import trace_sets
from .styles import of_report

log = logging.getLogger(__name__)

#: A per-context critical-difference diagram needs this many successful runs per optimizer.
CD_MIN_RUNS = 5
#: The critical-difference diagram across blocks needs this many blocks (contexts).
CD_MIN_BLOCKS = 5


def _draw(figs: dict[str, Any], title: str, data: Any,
          draw: Callable[..., Path | str], *args: Any) -> None:
    """Plan ``figs[title] = draw(data, *args)`` (a path or why not drawn), or ``data``: a reason."""
    figs[title] = data if isinstance(data, str) else (lambda: draw(data, *args))


def _one(title: str, plan: Callable[[], Path | str]) -> Path | str:
    try:
        return plan()
    except Exception as exc:  # noqa: BLE001 - a figure's fault costs that figure only
        if write_refused(exc):  # a full disk is the report's failure, not the figure's
            raise
        log.debug("figure %s failed", title, exc_info=True)
        return f"failed: {type(exc).__name__}: {exc}"


def draw_all(data: Any, file: Callable[[str, str, str], Path],
             progress: Stages | None = None) -> dict[str, Path | str]:
    """Every core figure of a full report, in order: title -> PNG path, or why it was not
    drawn; ``file(kind, name, suffix)`` claims a path in the report folder."""
    figs: dict[str, Any] = {}
    records, rows, df = data.loaded.records, data.rows, data.tests.df
    style_of = of_report(data)  # one style per optimizer in every figure
    traces = trace_sets(records, rows)
    _draw(figs, "Convergence", figures.convergence_panels(
        traces, *reference_levels(records, rows)) if traces else "no traces in the records",
        figures.draw_convergence, file("figures", "convergence", ".png"), style_of)
    for p in sorted(df["problem"].unique()):
        _draw(figs, f"Per-run metric, {p}", figures.runs_metric_data(df, p),
              figures.draw_runs_metric, file("figures", f"runs_{p}", ".png"))
        _draw(figs, f"Median per-run absolute relative error per parameter, {p}",
              figures.error_heatmap_data(df, p), figures.draw_error_heatmap,
              file("figures", f"errors_{p}", ".png"))
    _cd_figures(figs, data, file, style_of)
    for context in sorted({h.context for h in data.hits}):
        _draw(figs, f"Fixed-target ECDF, {context}", data.hits, anytime.ecdf_figure, context,
              file("figures", f"ecdf_{context}", ".png"), style_of)
    # every plan drawn in its place, side by side (:func:`.forked.run_forked`)
    planned = [(title, f) for title, f in figs.items() if callable(f)]
    if progress is not None:
        progress.stage("figures", len(planned))
    drawn = run_forked([lambda t=t, f=f: _one(t, f) for t, f in planned],
                       None if progress is None else progress.step)
    figs.update((t, d) for (t, _), d in zip(planned, drawn, strict=True))
    return figs


def _cd_figures(figs: dict[str, Path | str], data: Any,
                file: Callable[[str, str, str], Path], style_of: Any = None) -> None:
    """The critical-difference diagrams (they need the tests)."""
    t = data.tests
    df, pairs, fr, alpha = t.df, t.pairs, t.fr, data.alpha
    by_inst = t.by_inst.get("metric", {})
    for context in sorted(df["context"].unique()):
        g = df[(df["context"] == context) & (df["status"] == "ok")]
        n = g.groupby("algorithm").size()
        title = f"Critical-difference diagram, {context}"
        if len(n) < 2 or n.min() < CD_MIN_RUNS:
            figs[title] = (f"needs at least 2 optimizers with at least {CD_MIN_RUNS} successful "
                           f"runs each (found {len(n)} optimizer(s), fewest runs {n.min()})")
            continue
        metric = g["metric_name"].iloc[0]
        inst = by_inst.get(context)
        if inst is not None and inst.mean_ranks is None:
            figs[title] = f"the runs pair by instance and the Friedman test {inst.note}"
            continue
        test = pairs[pairs["context"] == context]["test"].iloc[0]
        _draw(figs, title, figures.cd_data(
            inst.mean_ranks if inst is not None else stats.mean_ranks_in_context(df, context),
            stats.pvalue_matrix(pairs, context)), figures.draw_cd,
            f"{context}: bars join optimizers not significantly different "
            f"({test}, Holm, α={alpha})",
            (f"mean rank of each optimizer over the {len(inst.blocks)} instances, by per-run "
             f"{metric} (1 = best)") if inst is not None else
            (f"mean rank of each optimizer's runs among all {len(g)} runs of the context, "
             f"by per-run {metric} (1 = best)"),
            file("figures", f"cd_{context}", ".png"), alpha, style_of)
    title = "Critical-difference diagram across blocks"
    if fr is None or fr.mean_ranks is None or len(fr.blocks) < CD_MIN_BLOCKS:
        found = 0 if fr is None else len(fr.blocks)
        figs[title] = (f"needs a Friedman test over at least {CD_MIN_BLOCKS} blocks (contexts) "
                       f"with the same optimizers; found {found}")
    else:
        _draw(figs, title, figures.cd_data(fr.mean_ranks, fr.nemenyi), figures.draw_cd,
              f"Across {len(fr.blocks)} blocks: bars join optimizers not significantly "
              f"different (Nemenyi, α={alpha})",
              "mean rank of each optimizer's median per-run metric over the blocks (1 = best)",
              file("figures", "cd_blocks", ".png"), alpha, style_of)
