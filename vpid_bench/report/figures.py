"""The core report's figures (matplotlib, PNG, Agg backend), each readable alone, lower is
better on every metric axis. Each comes in two halves, so that what a figure shows is tested
without drawing it: a *data* function reduces the records or runs to small plain data (or a
string saying why the figure cannot be drawn), a *draw* function writes one PNG from it and
returns its path."""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .stats import compact_letters
from .styles import legend, lookup

#: Resolution of every PNG (dots per inch).
DPI = 110
#: zlib level of the PNG files: 1 (not 6) saves 5 % of the drawing time, files 5-7 % larger.
PNG_COMPRESS_LEVEL = 1
#: A convergence curve keeps at most this many points (step corners; see :func:`thin_steps`).
MAX_CURVE_POINTS = 400
#: The common evaluation grid of a context's runs has at most this many points.
MAX_GRID_POINTS = 4000


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig: Any, path: Path) -> Path:
    """Write ``fig`` as a PNG at ``path`` (folder created), close it, return ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, bbox_inches="tight",
                pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    _plt().close(fig)
    return path


def colours(n: int) -> list[Any]:
    """``n`` distinct colours: matplotlib's colour cycle when it has enough, else ``n`` evenly
    spaced hues (seaborn's ``husl``): a repeated colour would make two curves one."""
    cycle = _plt().rcParams["axes.prop_cycle"].by_key().get("color") or ["C0"]
    if n <= len(cycle):
        return list(cycle[:n])
    import seaborn as sns

    return list(sns.color_palette("husl", n))


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


# --- convergence -----------------------------------------------------------------------------

def step_values(ev: np.ndarray, best: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """A best-so-far trace as a step function read at ``grid`` (NaN before the first batch)."""
    idx = np.searchsorted(ev, grid, side="right") - 1
    return np.where(idx >= 0, best[np.clip(idx, 0, None)], np.nan)


def thin_steps(x: np.ndarray, *ys: np.ndarray, max_points: int = MAX_CURVE_POINTS
               ) -> tuple[np.ndarray, ...]:
    """Fewer points for ``steps-post`` curves, (x, *ys): points where no y changes dropped
    (nothing drawn changes); past ``max_points``, the x range cut into equal bins, each
    keeping its last point: exact at every kept point, off by at most one bin between."""
    x = np.asarray(x, float)
    ys = tuple(np.asarray(y, float) for y in ys)
    if x.size <= 2:
        return (x, *ys)
    same = np.ones(x.size - 1, bool)
    for y in ys:
        same &= (y[1:] == y[:-1]) | (np.isnan(y[1:]) & np.isnan(y[:-1]))
    keep = np.concatenate([[True], ~same])
    keep[-1] = True  # the curve runs to the last evaluation
    x, ys = x[keep], tuple(y[keep] for y in ys)
    if x.size > max_points:
        n_bins = max(max_points - 1, 1)
        width = (x[-1] - x[0]) / n_bins
        b = np.minimum(np.floor((x - x[0]) / width), n_bins - 1).astype(np.int64)
        last_of_bin = np.concatenate([b[1:] != b[:-1], [True]])
        last_of_bin[0] = True
        x, ys = x[last_of_bin], tuple(y[last_of_bin] for y in ys)
    return (x, *ys)


TraceSets = Mapping[str, Mapping[str, Sequence[tuple[np.ndarray, np.ndarray]]]]


def nan_column_quantiles(m: np.ndarray, qs: Sequence[float]) -> np.ndarray:
    """``np.nanquantile(m, qs, axis=0)`` of a 2-D ``m`` (the same numbers, tested) with one
    ``np.quantile`` call per count of non-NaN values: numpy's loops over columns in Python
    took minutes over an archive."""
    m = np.asarray(m, dtype=float)
    out = np.full((len(qs), m.shape[1]), np.nan)
    counts = np.count_nonzero(~np.isnan(m), axis=0)
    ordered = np.sort(m, axis=0)  # NaN last
    for k in np.unique(counts):
        if k:
            cols = counts == k
            out[:, cols] = np.quantile(ordered[:k, cols], qs, axis=0)
    return out


def convergence_panels(traces: TraceSets, f_true: Mapping[str, float] | None = None,
                       f_opt: Mapping[str, float] | None = None) -> list[dict[str, Any]]:
    """The convergence figure's data, one panel per context with a finite value: each
    optimizer's quartiles over its runs of the best-so-far on the context's evaluation grid,
    thinned. ``traces[context][algorithm]``: each run's (evaluations, best) arrays."""
    panels = []
    for context in sorted(traces):
        by_alg = traces[context]
        evs = [ev for runs in by_alg.values() for ev, _ in runs]
        if not evs:
            continue
        grid = np.unique(np.concatenate(evs))
        if grid.size > MAX_GRID_POINTS:
            grid = np.unique(np.round(np.linspace(grid[0], grid[-1], MAX_GRID_POINTS)))
        curves, n_runs, found = [], set(), []
        for algorithm in sorted(by_alg):
            m = np.vstack([step_values(ev, best, grid) for ev, best in by_alg[algorithm]])
            m[~np.isfinite(m)] = np.nan
            with_value = ~np.all(np.isnan(m), axis=1)
            if not with_value.any():
                continue
            n_runs.add(int(with_value.sum()))
            v = m[np.isfinite(m)]  # what set_log_y decides on: least, largest, least non-zero
            nonzero = np.abs(v[v != 0])
            found.append(np.array([v.min(), v.max()] + ([nonzero.min()] if nonzero.size else [])))
            cols = ~np.all(np.isnan(m), axis=0)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                q = nan_column_quantiles(m[:, cols], [0.25, 0.5, 0.75])
            x, q25, q50, q75 = thin_steps(grid[cols], *q)
            curves.append({"algorithm": algorithm, "x": x, "q25": q25, "median": q50, "q75": q75})
        if not curves:
            continue
        panels.append({"context": context, "curves": curves, "runs": sorted(n_runs),
                       "values": np.concatenate(found), "f_true": (f_true or {}).get(context),
                       "f_opt": (f_opt or {}).get(context)})
    return panels


def draw_convergence(panels: Sequence[Mapping[str, Any]], path: Path,
                     style_of: Mapping[str, Any] | None = None) -> Path | str:
    """Median best objective vs evaluations per optimizer with its IQR band, a panel per
    context, log y axis; dashed: the objective at the truth, dotted: the record optimum."""
    if not panels:
        return "no finite objective values in the traces"
    look = lookup(style_of, [c["algorithm"] for p in panels for c in p["curves"]])
    ncol = min(len(panels), 2)
    nrow = -(-len(panels) // ncol)
    fig, axes = _plt().subplots(nrow, ncol, figsize=(6.5 * ncol, 4.2 * nrow), squeeze=False)
    for ax, p in zip(axes.flat, panels, strict=False):
        for c in p["curves"]:
            st = look[c["algorithm"]]
            ax.plot(c["x"], c["median"], **st.mpl(), label=c["algorithm"], drawstyle="steps-post")
            ax.fill_between(c["x"], c["q25"], c["q75"], color=st.colour, alpha=0.12,
                            step="post", linewidth=0)
        values = np.asarray(p["values"], float)
        for level, ls, lw, what in ((p.get("f_true"), "--", 1.0, "f at the true parameters"),
                                    (p.get("f_opt"), ":", 1.2, "record optimum f*")):
            if level is not None and math.isfinite(level):
                ax.axhline(level, color="black", ls=ls, lw=lw,
                           label=f"{what}, median over instances ({level:.4g})")
                values = np.append(values, level)
        scale = set_log_y(ax, values)
        ax.set_title(f"{p['context']}\n(runs per optimizer: {', '.join(map(str, p['runs']))})")
        ax.set_xlabel("objective evaluations used")
        ax.set_ylabel("best objective value so far" + (" (log scale)" if scale == "log"
                                                       else " (symmetric log scale)"))
        legend(ax, len(p["curves"]), title="optimizer (median, IQR band)", title_fontsize=8)
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    fig.suptitle("Convergence: median best objective vs evaluations (band = interquartile range)")
    fig.tight_layout()
    return save(fig, path)


# --- per-run metric --------------------------------------------------------------------------

def runs_metric_data(df: Any, problem: str) -> dict[str, Any] | str:
    """The successful runs' finite metric values per (optimizer, context) of ``problem``."""
    d = df[(df["problem"] == problem) & (df["status"] == "ok") & np.isfinite(df["metric"])]
    if d.empty:
        return f"no successful runs with a finite metric for {problem}"
    names = sorted(d["metric_name"].unique())
    v = d["metric"].to_numpy(float)  # log axis: all positive, spanning more than 50 times
    values = {(str(a), str(c)): g["metric"].to_numpy(float)
              for (a, c), g in d.groupby(["algorithm", "context"], sort=True)}
    return {"problem": problem, "name": names[0] if len(names) == 1 else "metric",
            "order": sorted(map(str, d["algorithm"].unique())),
            "hue_order": sorted(map(str, d["context"].unique())), "values": values,
            "log": bool(np.all(v > 0) and v.max() / v.min() > 50)}


def draw_runs_metric(data: Mapping[str, Any], path: Path) -> Path | str:
    """Per-run metric per optimizer, grouped by context: a box (whiskers to 1.5 IQR) and every
    run as a dot (jittered by a fixed generator), one colour per context."""
    order, hue_order = data["order"], data["hue_order"]
    m = max(1, len(hue_order))
    fig, ax = _plt().subplots(figsize=(max(6.0, 0.9 * len(order) * m + 2), 4.6))
    slot = 0.8 / m
    rng = np.random.default_rng(0)
    palette = colours(len(hue_order))
    for j, (colour, context) in enumerate(zip(palette, hue_order, strict=True)):
        pos, vals = [], []
        for i, algorithm in enumerate(order):
            v = data["values"].get((algorithm, context))
            if v is None or not len(v):
                continue
            pos.append(i - 0.4 + (j + 0.5) * slot)
            vals.append(v)
        if not vals:
            continue
        props = {"color": colour, "linewidth": 1.2}
        ax.boxplot(vals, positions=pos, widths=0.8 * slot, showfliers=False,
                   manage_ticks=False, boxprops=props, whiskerprops=props, capprops=props,
                   medianprops=props)
        xs = np.concatenate([np.full(len(v), p) + rng.uniform(-0.15, 0.15, len(v)) * slot
                             for p, v in zip(pos, vals, strict=True)])
        ax.scatter(xs, np.concatenate(vals), s=9, color=colour, alpha=0.6, linewidths=0, zorder=3)
    ax.set_xticks(range(len(order)), order)
    ax.set_xlim(-0.5, len(order) - 0.5)
    if data["log"]:
        ax.set_yscale("log")
    ax.set_xlabel("optimizer")
    ax.set_ylabel(("best objective value f" if data["name"] == "f_best" else
                   f"{data['name']} of the best vector") + " (lower is better)")
    ax.set_title(f"Per-run {data['name']} of every run, {data['problem']} "
                 "(box = median and IQR, dots = runs)")
    from matplotlib.patches import Patch

    ax.legend(handles=[Patch(facecolor="none", edgecolor=c, label=h, linewidth=1.2)
                       for c, h in zip(palette, hue_order, strict=True)],
              title="context", fontsize=8, title_fontsize=8)
    return save(fig, path)


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


def error_heatmap_data(df: Any, problem: str) -> dict[str, Any] | str:
    """Per (optimizer, context) row and parameter column, the median |relative error| (%)."""
    d = df[(df["problem"] == problem) & (df["status"] == "ok")]
    eps_cols = [c for c in df.columns if c.startswith("eps.") and d[c].notna().any()]
    if d.empty or not eps_cols:
        return f"no relative errors for {problem} (the problem has no true parameter values)"
    rows, vals = [], []
    for (a, c), g in d.groupby(["algorithm", "context"], sort=True):
        e = np.abs(g[eps_cols].to_numpy(float))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a column without any value
            vals.append(np.nanmedian(e, axis=0))
        rows.append(f"{a}  |  {c}")
    return {"problem": problem, "rows": rows, "columns": [c[4:] for c in eps_cols],
            "values": np.vstack(vals)}


def draw_error_heatmap(data: Mapping[str, Any], path: Path) -> Path | str:
    """Median per-run |relative error| (%) of each parameter, per optimizer and context, on a
    log colour scale (not the mean vector's error: opposite signs cancel in a mean)."""
    import matplotlib.colors as mcolors
    from matplotlib.ticker import FuncFormatter

    plt = _plt()
    vals = np.asarray(data["values"], float)
    rows, cols = data["rows"], data["columns"]
    pos = vals[np.isfinite(vals) & (vals > 0)]
    vmin = max(float(pos.min()), 1e-4) if pos.size else 1e-3
    vmax = max(float(pos.max()), vmin * 10) if pos.size else 1.0
    norm = mcolors.LogNorm(vmin=vmin, vmax=vmax)
    cmap = plt.get_cmap("viridis_r")
    shown = np.ma.masked_invalid(np.clip(vals, vmin, None))
    fig, ax = plt.subplots(figsize=(0.9 * len(cols) + 4, 0.42 * len(rows) + 2))
    im = ax.imshow(shown, cmap=cmap, norm=norm, aspect="auto", interpolation="nearest")
    if len(cols) <= 14:
        # Dark text on light cells, white on dark (relative luminance, as seaborn decides).
        rgb = cmap(norm(np.clip(np.nan_to_num(vals, nan=vmin), vmin, None)))[..., :3]
        rgb = np.where(rgb <= 0.03928, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
        light = rgb @ np.array([0.2126, 0.7152, 0.0722]) > 0.408
        for (i, j), v in np.ndenumerate(vals):
            if math.isfinite(v):
                ax.text(j, i, error_label(v), ha="center", va="center", fontsize=10,
                        color=".15" if light[i, j] else "w")
    cbar = fig.colorbar(im, ax=ax)
    cbar.set_label("median per-run |relative error| (%), log scale")
    cbar.ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
    ax.set_xticks(range(len(cols)), cols)
    ax.set_yticks(range(len(rows)), rows)
    ax.tick_params(length=0)
    for spine in ax.spines.values():
        spine.set_visible(False)
    ax.set_xlabel("parameter")
    ax.set_ylabel("optimizer  |  context")
    ax.set_title(f"Median per-run |relative error| of each parameter (%), {data['problem']}")
    return save(fig, path)


# --- critical-difference diagram -------------------------------------------------------------

def cd_data(ranks: Any, pvalues: Any) -> dict[str, Any] | str:
    """The CD diagram's data: (name, mean rank) best first, and the p-value matrix in that
    order (``pvalues``: a square DataFrame indexed by the names)."""
    if ranks is None or len(ranks) < 2:
        return "fewer than 2 optimizers to compare"
    items = sorted(((str(k), float(v)) for k, v in dict(ranks).items()), key=lambda kv: kv[1])
    names = [k for k, _ in items]
    return {"ranks": items, "p": pvalues.loc[names, names].to_numpy(float)}


def cd_bars(names: list[str], p: np.ndarray, alpha: float) -> list[list[str]]:
    """The bars of a critical-difference diagram: each group (two or more) no pair of which
    differs significantly, the columns of the compact letter display, best first."""
    different = {frozenset((names[i], names[j])) for i in range(len(names))
                 for j in range(i + 1, len(names)) if p[i, j] < alpha}
    letters = compact_letters(list(names), different)
    groups = sorted({letter for text in letters.values() for letter in text})
    return [members for members in ([n for n in names if g in letters[n]] for g in groups)
            if len(members) > 1]


def draw_cd(data: Mapping[str, Any], title: str, axis_label: str, path: Path,
            alpha: float, style_of: Mapping[str, Any] | None = None) -> Path | str:
    """Critical-difference diagram in Demšar's (2006) layout: mean ranks on a top axis, a bar
    per group of :func:`cd_bars`, each optimizer's elbow line to its label (better half
    left, the rest right), no two lines crossing."""
    names = [name for name, _ in data["ranks"]]
    look = lookup(style_of, names)
    rank = {name: r for name, r in data["ranks"]}
    levels: list[float] = []  # the right end of the last bar placed on each level
    placed: list[tuple[float, float, int]] = []
    for members in cd_bars(names, np.asarray(data["p"], float), alpha):
        lo, hi = rank[members[0]], rank[members[-1]]
        level = next((k for k, end in enumerate(levels) if lo > end + 0.05), len(levels))
        levels[level:level + 1] = [hi]
        placed.append((lo, hi, level))
    step = 0.5  # vertical units between bar levels and between label rows
    half = (len(names) + 1) // 2
    lo_r, hi_r = min(rank.values()), max(rank.values())
    margin = 0.25 * (hi_r - lo_r) + 0.5
    left_x, right_x = lo_r - margin, hi_r + margin
    rows = -step * (len(levels) + 1 + np.arange(half))
    fig, ax = _plt().subplots(figsize=(8, 1.3 + 0.3 * (half + len(levels))))
    for lo, hi, level in placed:
        ax.plot([lo - 0.03, hi + 0.03], [-step * (level + 1)] * 2, color="k", linewidth=3,
                solid_capstyle="butt", zorder=3)
    sides = [(names[:half], left_x, "right"), (names[half:][::-1], right_x, "left")]
    for i, (group, x_label, align) in enumerate(sides):
        for row, name in enumerate(group):
            colour = look[name].colour
            r = rank[name]
            ax.plot([r, r, x_label], [0, rows[row], rows[row]], color=colour, linewidth=1)
            ax.scatter([r], [0], color=colour, zorder=4)
            text = f"{name} ({r:.2f})" if i == 0 else f"({r:.2f}) {name}"
            ax.text(x_label + (-0.05 if i == 0 else 0.05), rows[row], text, color=colour,
                    va="center", ha=align, fontsize=9)
    ax.set_xlim(left_x - 1.6 * margin, right_x + 1.6 * margin)
    ax.set_ylim(rows[-1] - step, step)
    ax.set_xticks(range(math.ceil(lo_r - 0.5), math.floor(hi_r + 0.5) + 1))
    ax.yaxis.set_visible(False)
    for side in ("right", "left", "bottom"):
        ax.spines[side].set_visible(False)
    ax.spines["top"].set_bounds(lo_r - 0.5, hi_r + 0.5)
    ax.xaxis.set_ticks_position("top")
    ax.spines["top"].set_position(("data", 0))
    ax.set_title(f"{title}\naxis: {axis_label}", fontsize=9)
    return save(fig, path)
