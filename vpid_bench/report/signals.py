"""The measured-vs-fitted figure of any problem that offers ``signals``: from the
``best_signals.csv`` of the best job (:mod:`vpid_bench.store.artifacts`; the problem is never
rebuilt), per channel the measured and fitted signal and, under it, the residual."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..store.artifacts import BEST_SIGNALS, BadArtifactError, read_best_signals
from .figures import _plt
from .sections import Contribution, ReportContext, Section

TITLE = "Measured vs fitted signals of the best run"


def draw_signals(t: Any, channels: Mapping[str, tuple[Any, Any]], units: Mapping[str, str],
                 title: str) -> Any:
    """Per channel a signal panel and a residual panel under it; one legend above all."""
    names = sorted(channels)
    ratios = [r for _ in names for r in (3, 1.2)]
    fig, axes = _plt().subplots(2 * len(names), 1, figsize=(7.5, 3.6 * len(names) + 0.8),
                             sharex=True, gridspec_kw={"height_ratios": ratios})
    t = np.asarray(t, dtype=float)
    for i, ch in enumerate(names):
        measured, fitted = channels[ch]
        unit = units.get(ch, "")
        ax, axr = axes[2 * i], axes[2 * i + 1]
        if measured is not None:
            ax.plot(t, measured, color="0.35", lw=1.0, label="measured")
        if fitted is not None:
            ax.plot(t, fitted, color="C3", lw=1.3, ls="--", label="fitted")
        ax.set_ylabel(f"{ch}" + (f" ({unit})" if unit else ""))
        ax.grid(alpha=0.3)
        if measured is not None and fitted is not None:
            axr.plot(t, np.asarray(measured) - np.asarray(fitted), color="C0", lw=0.9,
                     label="residual (measured − fitted)")
        axr.axhline(0.0, color="0.6", lw=0.6)
        axr.set_ylabel("residual" + (f"\n({unit})" if unit else ""))
        axr.grid(alpha=0.3)
    axes[-1].set_xlabel("time t (s)")
    handles, labels = [], []
    for ax in axes[:2]:
        h, lab = ax.get_legend_handles_labels()
        handles += h
        labels += lab
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    fig.legend(handles, labels, loc="upper center", ncol=3, fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, 0.955))
    return fig


def section(ctx: ReportContext) -> Contribution | None:
    """The figure of the best run of ``ctx``'s problem (full report only; ``None``: no signals)."""
    ok = [(row, rec) for row, rec in zip(ctx.rows, ctx.records, strict=True)
          if row["status"] == "ok" and math.isfinite(row["metric"])]
    if ctx.short or not ok:
        return None
    row, rec = min(ok, key=lambda item: item[0]["metric"])
    path = Path(ctx.job_dir(rec)) / BEST_SIGNALS
    if not path.exists() and not path.is_symlink():
        return None
    try:
        sig = read_best_signals(path)
    except BadArtifactError as exc:
        return Contribution(sections=(Section(TITLE, ctx.para(
            f"Not drawn: {ctx.escape(exc)}. Each job writes `{BEST_SIGNALS}` (the signals of "
            "its best run); rerun the job to get it.")),))
    src = sig.source
    where = (f"{row['algorithm']}, {row['context']}, the best run of its job (run "
             f"{src.get('run_index')}, {src.get('ranked_by')} = {ctx.fmt(src.get('value'))})")
    png = ctx.save_figure(draw_signals(sig.t, sig.channels, sig.units,
                                       f"Measured vs fitted signals: {where}"),
                          f"signals_{ctx.problem}")
    text = ctx.para(
        f"The job of the best run by {ctx.escape(row['metric_name'])} "
        f"({ctx.escape(row['algorithm'])}, {ctx.escape(row['context'])}) recorded the signals "
        "of its own best run: the measured record and the response of the identified vector, "
        "and under each channel the residual measured − fitted. A residual with structure "
        "(not noise-like) is model error or a fit that stopped short.")
    return Contribution(sections=(Section(TITLE, text, (png,)),))
