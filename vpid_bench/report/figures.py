"""The report's figures (seaborn/matplotlib, PNG, Agg backend), each readable on its own.

Every function writes one PNG and returns its path, or returns a string saying why the
figure was skipped (no data of that kind). Lower is better on every metric axis.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

DPI = 110


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def slug(text: str) -> str:
    """A file-name-safe form of ``text``."""
    return re.sub(r"[^A-Za-z0-9._=-]+", "_", text).strip("_") or "x"


def metric_label(metric_name: str) -> str:
    """Axis label of the per-run metric."""
    return "NoRE of the best vector (%)" if metric_name == "NoRE" else "best objective value f"


def _save(fig: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, bbox_inches="tight")
    _plt().close(fig)
    return path


def _use_log(values: np.ndarray) -> bool:
    v = values[np.isfinite(values)]
    return bool(v.size and np.all(v > 0) and v.max() / v.min() > 50)


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


def convergence(traces: Any, path: Path) -> Path | str:
    """Median best objective vs evaluations per optimizer, IQR band, one panel per context."""
    if traces is None or traces.empty:
        return "no traces in the records"
    import seaborn as sns

    plt = _plt()
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
        if _use_log(d["best"].to_numpy(float)):
            ax.set_yscale("log")
        n = d.groupby("algorithm")["run_id"].nunique()
        ax.set_title(f"{context}\n(runs per optimizer: {', '.join(map(str, sorted(set(n))))})")
        ax.set_xlabel("objective evaluations used")
        ax.set_ylabel("best objective value so far")
        ax.legend(title="optimizer (median, IQR band)", fontsize=8, title_fontsize=8)
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
    name = d["metric_name"].iloc[0]
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


def rel_error_heatmap(meanvec: Any, problem: str, path: Path) -> Path | str:
    """Signed relative error (%) of each parameter of the mean identified vector."""
    import seaborn as sns

    plt = _plt()
    if meanvec is None or meanvec.empty:
        return "no true parameter values in the records"
    d = meanvec[(meanvec["problem"] == problem) & (meanvec["source"] == "ours")
                & (meanvec["quantity"] == "eps_percent")]
    if d.empty:
        return f"no true parameter values for {problem}"
    params = [c for c in d.columns if c not in {"context", "problem", "ps", "algorithm",
                                                 "n_runs", "source", "quantity", "nore", "note"}
              and d[c].notna().any()]
    mat = d.set_index(d["algorithm"] + "  |  " + d["context"])[params].astype(float)
    lim = float(np.nanmax(np.abs(mat.to_numpy()))) or 1.0
    fig, ax = plt.subplots(figsize=(1.0 * len(params) + 4, 0.45 * len(mat) + 2))
    sns.heatmap(mat, annot=len(params) <= 12, fmt=".2f", cmap="RdBu_r", center=0.0,
                vmin=-lim, vmax=lim, cbar_kws={"label": "relative error ε of the mean (%)"},
                ax=ax)
    ax.set_xlabel("parameter")
    ax.set_ylabel("optimizer  |  context")
    ax.set_title(f"Relative error of the mean identified vector per parameter (%), {problem}")
    return _save(fig, path)


def signals(sig: dict[str, np.ndarray] | None, title: str, path: Path,
            units: dict[str, str] | None = None) -> Path | str:
    """Measured vs fitted signals of one run (the paper's Fig. 2), one panel per channel."""
    if not sig or "t" not in sig:
        return "the problem provides no signals"
    plt = _plt()
    channels = sorted({k.rsplit(":", 1)[0] for k in sig if ":" in k})
    if not channels:
        return "the problem provides no signal channels"
    units = units or {}
    t = np.asarray(sig["t"], dtype=float)
    fig, axes = plt.subplots(len(channels), 1, figsize=(7.5, 2.8 * len(channels)),
                             squeeze=False, sharex=True)
    for ax, ch in zip(axes[:, 0], channels, strict=True):
        unit = units.get(ch) or ("m/s²" if ch.endswith("''") else "")
        for kind, style in (("measured", dict(color="0.35", lw=1.0)),
                            ("fitted", dict(color="C3", lw=1.4, ls="--"))):
            y = sig.get(f"{ch}:{kind}")
            if y is not None:
                ax.plot(t, np.asarray(y, dtype=float), label=kind, **style)
        ax.set_ylabel(f"{ch}" + (f" ({unit})" if unit else ""))
        ax.legend(fontsize=8, loc="upper right")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time t (s)")
    fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)


def cd_diagram(ranks: Any, pvalues: Any, title: str, path: Path, alpha: float) -> Path | str:
    """Critical-difference diagram (scikit-posthocs): mean ranks on the axis, bars join the
    optimizers that are not significantly different at ``alpha``."""
    if ranks is None or len(ranks) < 2:
        return "fewer than 2 optimizers to compare"
    import scikit_posthocs as sp

    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 1.2 + 0.35 * len(ranks)))
    sp.critical_difference_diagram(ranks, pvalues, ax=ax, alpha=alpha)
    ax.set_title(title + "\naxis: mean rank (1 = best)", fontsize=9)
    return _save(fig, path)
