"""The core report's figures (seaborn/matplotlib, PNG, Agg backend), each readable alone.

Every function writes one PNG and returns its path, or returns a string saying why the
figure was not drawn. Lower is better on every metric axis. Problem-specific figures (e.g.
measured vs fitted signals) come from the problem's plugin through a report section.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

DPI = 110


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def metric_label(metric_name: str) -> str:
    """Axis label of the per-run metric."""
    if metric_name == "f_best":
        return "best objective value f"
    return f"{metric_name} of the best vector"


def _save(fig: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, bbox_inches="tight")
    _plt().close(fig)
    return path


def _use_log(values: np.ndarray) -> bool:
    v = values[np.isfinite(values)]
    return bool(v.size and np.all(v > 0) and v.max() / v.min() > 50)


def set_log_y(ax: Any, values: np.ndarray) -> str:
    """A logarithmic y axis when every finite value is positive, else a symmetric-log one
    (linear within the smallest non-zero magnitude); returns the scale name."""
    v = values[np.isfinite(values)]
    if v.size and np.all(v > 0):
        from matplotlib.ticker import FuncFormatter, NullFormatter

        ax.set_yscale("log")
        plain = FuncFormatter(lambda y, _: f"{y:g}")
        ax.yaxis.set_major_formatter(plain)
        # A narrow range gets labelled minor ticks too (else it may show one label or none).
        ax.yaxis.set_minor_formatter(plain if v.max() / v.min() < 100 else NullFormatter())
        return "log"
    nonzero = np.abs(v[v != 0])
    ax.set_yscale("symlog", linthresh=float(nonzero.min()) if nonzero.size else 1.0)
    return "symlog"


def convergence_frame(traces: Any, max_points: int = 200) -> Any:
    """Best-so-far of every run on a common evaluation grid per context (step functions:
    the value at ``e`` evaluations is the best after the last batch that ended at or before
    ``e``). Columns: context, algorithm, run_id, evaluations, best."""
    import pandas as pd

    out = []
    for context, g in traces.groupby("context", sort=True):
        grid = np.unique(g["evaluations"].to_numpy(float))
        if grid.size > max_points:
            grid = np.unique(np.round(np.linspace(grid[0], grid[-1], max_points)))
        for (algorithm, rid), r in g.groupby(["algorithm", "run_id"], sort=True):
            ev = r["evaluations"].to_numpy(float)
            best = r["best"].to_numpy(float)
            idx = np.searchsorted(ev, grid, side="right") - 1
            val = np.where(idx >= 0, best[np.clip(idx, 0, None)], np.nan)
            out.append(pd.DataFrame({"context": context, "algorithm": algorithm, "run_id": rid,
                                     "evaluations": grid, "best": val}))
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame()


def convergence(traces: Any, path: Path, f_true: Mapping[str, float] | None = None,
                f_opt: Mapping[str, float] | None = None) -> Path | str:
    """Median best objective vs evaluations per optimizer, IQR band, one panel per context,
    on a logarithmic y axis; a dashed line at the objective of the true parameters where
    ``f_true[context]`` is known, and a dotted one at the record optimum ``f*`` (the lowest
    objective the record allows) where ``f_opt[context]`` is; both are medians over the
    context's instances (noise records)."""
    if traces is None or traces.empty:
        return "no traces in the records"
    import seaborn as sns

    plt = _plt()
    f_true = dict(f_true or {})
    f_opt = dict(f_opt or {})
    data = convergence_frame(traces)
    data = data[np.isfinite(data["best"])]
    if data.empty:
        return "no finite objective values in the traces"
    contexts = sorted(data["context"].unique())
    ncol = min(len(contexts), 2)
    nrow = -(-len(contexts) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(6.5 * ncol, 4.2 * nrow), squeeze=False)
    for ax, context in zip(axes.flat, contexts, strict=False):
        d = data[data["context"] == context]
        # Quartiles per (optimizer, grid point) in one groupby: what seaborn's lineplot with
        # estimator="median", errorbar=("pi", 50) draws, at a fraction of its cost.
        q = d.groupby(["algorithm", "evaluations"])["best"].quantile([0.25, 0.5, 0.75])
        q = q.unstack()
        algorithms = sorted(d["algorithm"].unique())
        for colour, algorithm in zip(sns.color_palette(n_colors=len(algorithms)), algorithms,
                                     strict=True):
            a = q.loc[algorithm]
            ax.plot(a.index, a[0.5], color=colour, label=algorithm, drawstyle="steps-post")
            ax.fill_between(a.index, a[0.25], a[0.75], color=colour, alpha=0.2, step="post",
                            linewidth=0)
        values = d["best"].to_numpy(float)
        ft = f_true.get(context)
        if ft is not None and math.isfinite(ft):
            ax.axhline(ft, color="black", ls="--", lw=1.0,
                       label=f"f at the true parameters, median over instances ({ft:.4g})")
            values = np.append(values, ft)
        fo = f_opt.get(context)
        if fo is not None and math.isfinite(fo):
            ax.axhline(fo, color="black", ls=":", lw=1.2,
                       label=f"record optimum f*, median over instances ({fo:.4g})")
            values = np.append(values, fo)
        scale = set_log_y(ax, values)
        n = d.groupby("algorithm")["run_id"].nunique()
        ax.set_title(f"{context}\n(runs per optimizer: {', '.join(map(str, sorted(set(n))))})")
        ax.set_xlabel("objective evaluations used")
        ax.set_ylabel("best objective value so far" + (" (log scale)" if scale == "log"
                                                       else " (symmetric log scale)"))
        ax.legend(title="optimizer (median, IQR band)", fontsize=8, title_fontsize=8, loc="best")
    for ax in list(axes.flat)[len(contexts):]:
        ax.set_visible(False)
    fig.suptitle("Convergence: median best objective vs evaluations (band = interquartile range)")
    fig.tight_layout()
    return _save(fig, path)


def runs_metric(df: Any, problem: str, path: Path) -> Path | str:
    """Per-run metric per optimizer, grouped by context (population size, noise, ...)."""
    import seaborn as sns

    plt = _plt()
    d = df[(df["problem"] == problem) & (df["status"] == "ok") & np.isfinite(df["metric"])]
    if d.empty:
        return f"no successful runs with a finite metric for {problem}"
    names = sorted(d["metric_name"].unique())
    name = names[0] if len(names) == 1 else "metric"
    order = sorted(d["algorithm"].unique())
    hue_order = sorted(d["context"].unique())
    fig, ax = plt.subplots(figsize=(max(6.0, 0.9 * len(order) * max(1, len(hue_order)) + 2), 4.6))
    sns.boxplot(data=d, x="algorithm", y="metric", hue="context", order=order,
                hue_order=hue_order, showfliers=False, ax=ax, fill=False)
    sns.stripplot(data=d, x="algorithm", y="metric", hue="context", order=order,
                  hue_order=hue_order, dodge=True, size=3, alpha=0.6, ax=ax, legend=False)
    if _use_log(d["metric"].to_numpy(float)):
        ax.set_yscale("log")
    ax.set_xlabel("optimizer")
    ax.set_ylabel(metric_label(name) + " (lower is better)")
    ax.set_title(f"Per-run {name} of every run, {problem} (box = median and IQR, dots = runs)")
    ax.legend(title="context", fontsize=8, title_fontsize=8)
    return _save(fig, path)


def error_label(v: float) -> str:
    """A cell of the error heatmap: readable from 1e-3 % to thousands of percent."""
    if not math.isfinite(v):
        return ""
    if v == 0:
        return "0"
    if v >= 100:
        return f"{v:.0f}"
    if v >= 1e-3:
        return f"{v:.3g}"
    return f"{v:.0e}"


def error_heatmap(df: Any, problem: str, path: Path) -> Path | str:
    """Median over the successful runs of each parameter's |relative error| (%), per
    optimizer and context, on a logarithmic colour scale (per-run errors, not the error of
    the mean vector, which hides scatter: errors of opposite sign cancel in a mean)."""
    import matplotlib.colors as mcolors
    import seaborn as sns

    plt = _plt()
    eps_cols = [c for c in df.columns if c.startswith("eps.")]
    d = df[(df["problem"] == problem) & (df["status"] == "ok")]
    eps_cols = [c for c in eps_cols if d[c].notna().any()]
    if d.empty or not eps_cols:
        return f"no relative errors for {problem} (the problem has no true parameter values)"
    med = d.groupby(["algorithm", "context"], sort=True)[eps_cols].agg(
        lambda s: float(np.median(np.abs(s.dropna()))) if s.notna().any() else np.nan)
    med.index = [f"{a}  |  {c}" for a, c in med.index]
    med.columns = [c[4:] for c in eps_cols]
    vals = med.to_numpy(float)
    pos = vals[np.isfinite(vals) & (vals > 0)]
    vmin = max(float(pos.min()), 1e-4) if pos.size else 1e-3
    vmax = max(float(pos.max()), vmin * 10) if pos.size else 1.0
    annot = np.vectorize(error_label)(vals) if len(med.columns) <= 14 else False
    fig, ax = plt.subplots(figsize=(0.9 * len(med.columns) + 4, 0.42 * len(med) + 2))
    sns.heatmap(med.clip(lower=vmin), annot=annot, fmt="", cmap="viridis_r",
                norm=mcolors.LogNorm(vmin=vmin, vmax=vmax),
                cbar_kws={"label": "median per-run |relative error| (%), log scale"}, ax=ax)
    from matplotlib.ticker import FuncFormatter

    ax.collections[0].colorbar.ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
    ax.set_xlabel("parameter")
    ax.set_ylabel("optimizer  |  context")
    ax.set_title(f"Median per-run |relative error| of each parameter (%), {problem}")
    return _save(fig, path)


def cd_diagram(ranks: Any, pvalues: Any, title: str, axis_label: str, path: Path,
               alpha: float) -> Path | str:
    """Critical-difference diagram (scikit-posthocs): mean ranks on the axis (described by
    ``axis_label``), bars join the optimizers not significantly different at ``alpha``."""
    if ranks is None or len(ranks) < 2:
        return "fewer than 2 optimizers to compare"
    import scikit_posthocs as sp

    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 1.4 + 0.35 * len(ranks)))
    sp.critical_difference_diagram(ranks, pvalues, ax=ax, alpha=alpha,
                                   label_fmt_left="{label} ({rank:.1f})",
                                   label_fmt_right="({rank:.1f}) {label}")
    ax.set_title(f"{title}\naxis: {axis_label}", fontsize=9)
    return _save(fig, path)
