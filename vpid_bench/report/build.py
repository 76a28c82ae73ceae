"""Build a report from run records: tables, tests, figures, ``report.md``.

:func:`build_report` reads the records below any number of job or sweep folders (merged),
and writes into ``out_dir``::

    report.md               the report, figures linked
    runs.csv                one row per run (``pandas.read_csv("runs.csv")``)
    tables/*.csv, *.tex     headline, Tables II/III reproduced, per-run statistics, tests
    figures/*.png           convergence, per-run metric, relative-error heatmap, signals, CD

It is honest whatever the numbers: every table says how many runs it rests on, the tests
say when they could not be run, and nothing claims significance that the Holm-corrected
p-values do not show.
"""

from __future__ import annotations

import dataclasses
import logging
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from . import figures, paper, render, stats, tables
from .light import sources_lines
from .load import LoadedRecords, NoRecordsError, load_records, runs_frame, traces_frame

__all__ = ["NoRecordsError", "Report", "build_report"]

log = logging.getLogger(__name__)


@dataclasses.dataclass
class Report:
    """What :func:`build_report` wrote and what it found wrong."""

    out_dir: Path
    report_md: Path
    headline: str
    n_records: int
    problems: list[str]
    files: list[Path]
    skipped_figures: dict[str, str]
    loaded: LoadedRecords

    @property
    def failures(self) -> list[str]:
        """One line per failed job, failed run or unreadable record file."""
        return self.loaded.failures


def _headline(stats_table: Any, verdicts: list[str]) -> Any:
    """The short table: per context, optimizers by median per-run metric."""
    import pandas as pd

    t = stats_table
    name = t["metric_name"]
    h = pd.DataFrame({
        "context": t["context"],
        "rank": t["rank_median"],
        "optimizer": t["algorithm"],
        "n": t["n_runs"],
        "metric": name,
        "median": t.get("median"),
        "IQR": [f"[{render.fmt(a)}, {render.fmt(b)}]" for a, b in
                zip(t.get("q1", np.nan * t["n_runs"]), t.get("q3", np.nan * t["n_runs"]),
                    strict=True)],
        "mean-vector NoRE": t["meanvec_nore"],
        "rank by mean-vector NoRE": t["rank_meanvec_nore"],
        "paper NoRE": t["paper_nore"],
        "median f": t.get("f_median"),
    })
    if verdicts and any(verdicts):
        h["vs random"] = verdicts
    return h.dropna(axis=1, how="all")


def _sources_text(paths: list[Path], loaded: LoadedRecords, df: Any) -> list[str]:
    failed = df[df["status"] != "ok"]
    return sources_lines(paths, loaded, list(zip(
        failed["algorithm"], failed["context"], failed["run_index"], failed["seed"],
        failed["error"], strict=True)))


HOW_TO_READ = """\
## How to read this report

- **Metric.** Where the problem knows the true parameters, runs are judged by NoRE, the
  Euclidean norm of the relative errors of the identified parameters in percent,
  `NoRE = ||100 (x - x_true) / x_true||`; otherwise by the best objective value `f` found.
  Lower is better for both. The column `metric` says which one a row uses.
- **Context.** Optimizers are compared within a context: one problem, one population size
  `ps` and one value of every other setting that varies across the records (noise level,
  noise seed, budget). Runs of different optimizer seeds are pooled.
- **Two rankings.** The paper ranks by the NoRE of the *mean* of the identified vectors
  (`mean-vector NoRE`). Averaging vectors can hide scatter (errors of opposite sign cancel),
  so this report ranks by the *median per-run* metric (`rank`), and shows both.
- **Significance.** Within a context: Kruskal–Wallis over all optimizers, then two-sided
  Mann–Whitney U for every pair, Holm-corrected over the pairs of that context;
  "significant" means `p_holm < {alpha}`. Effect size: Vargha–Delaney
  `A12 = P(metric_a > metric_b) + ties/2` (below 0.5: `a` tends to be better; |A12 - 0.5| of
  0.06 / 0.14 / 0.21 = small / medium / large). Across contexts (blocks): Friedman on the
  median metric per block, Nemenyi post-hoc for the critical-difference diagram, pairwise
  Wilcoxon signed-rank tests with Holm correction. With few runs or blocks, tests have little
  power: "not significant" is not "equal".
- **Baseline.** Random search, when it was run, is the line a useful optimizer must clear
  (significantly lower per-run metric at the same budget).
"""


def _mean_vector_md(meanvec: Any) -> list[str]:
    lines = ["## Tables II and III reproduced: the mean identified vector", ""]
    if meanvec is None or meanvec.empty:
        return lines + ["No context has true parameter values: the mean-vector table needs "
                        "them (the per-run statistics below use the objective).", ""]
    text = ("Mean over the successful runs of the identified vectors, its relative errors "
            "ε (%) and their norm NoRE (%).")
    if (meanvec["source"] == "paper").any():
        text += (f" `paper`: the published values, {paper.CITATION} (Table III's DE2 row "
                 "repaired, see the note). `difference` = ours − paper.")
    lines += [text, ""]
    for context, g in meanvec.groupby("context", sort=True):
        params = [c for c in g.columns if c not in {"context", "problem", "ps", "algorithm",
                                                     "n_runs", "source", "quantity", "nore",
                                                     "note"} and g[c].notna().any()]
        rows = g.copy()
        rows["row"] = rows["source"] + " " + rows["quantity"].map(
            {"mean": "mean", "eps_percent": "ε (%)"})
        show = rows[["algorithm", "n_runs", "row", *params, "nore"]].rename(
            columns={"n_runs": "n", "nore": "NoRE (%)"})
        lines += [f"### {context}", "", render.markdown(show), ""]
        notes = sorted({n for n in g["note"] if n and n != "ours - paper"})
        lines += [f"- {n}" for n in notes] + ([""] if notes else [])
    return lines


def _tests_md(kw: Any, pairs: Any, fr: stats.FriedmanResult, alpha: float) -> list[str]:
    lines = ["## Statistical tests", "", "### Kruskal–Wallis per context", "",
             render.markdown(kw), ""]
    lines += [f"### Pairwise Mann–Whitney U, Holm-corrected within each context "
              f"(significant: p_holm < {alpha})", ""]
    lines += [render.markdown(pairs) if not pairs.empty else "No pair to compare.", ""]
    lines += ["### Friedman across blocks", ""]
    if fr.note and fr.mean_ranks is None:
        lines += [f"Friedman test {fr.note}.", ""]
        return lines
    lines += [f"Blocks (contexts): {len(fr.blocks)}; optimizers present in every block: "
              f"{', '.join(fr.algorithms)}. Friedman χ² = {render.fmt(fr.statistic)}, "
              f"p = {render.fmt(fr.p)}. {fr.note}", "",
              "Mean rank per optimizer (1 = best): " + ", ".join(
                  f"{a} {r:.2f}" for a, r in fr.mean_ranks.items()), "",
              "Nemenyi post-hoc p-values:", "",
              render.markdown(fr.nemenyi.reset_index(names="optimizer")), "",
              f"Pairwise Wilcoxon signed-rank on the block medians, Holm-corrected "
              f"(significant: p_holm < {alpha}):", "", render.markdown(fr.wilcoxon), ""]
    return lines


def _signals_figure(df: Any, records: list[dict], problem: str, path: Path,
                    registry: Any = None) -> Path | str:
    ok = df[(df["problem"] == problem) & (df["status"] == "ok") & np.isfinite(df["metric"])]
    if ok.empty:
        return "no successful run"
    best = ok.loc[ok["metric"].idxmin()]
    rec = next(r for r in records if r["run_id"] == best["run_id"])
    x = rec["result"]["x_best"]
    if x is None or any(v is None for v in x):
        return "the best vector is not finite"
    try:
        from ..experiment import build_problem
        from ..plugins import Registry

        registry = registry if registry is not None else Registry()
        prob = build_problem(registry, {**rec["problem"]["config"], "name": problem})
        sig = prob.signals(np.asarray(x, dtype=float))
    except Exception as exc:  # a report must not die on a plugin's fault
        return f"could not rebuild the problem ({type(exc).__name__}: {exc})"
    title = (f"Measured vs fitted signals of the best run: {best['algorithm']}, "
             f"{best['context']}, {best['metric_name']} = {render.fmt(best['metric'])}"
             + (" %" if best["metric_name"] == "NoRE" else ""))
    return figures.signals(sig, title, path, getattr(prob, "signal_units", None))


def _figures(df: Any, loaded: LoadedRecords, meanvec: Any, pairs: Any,
             fr: stats.FriedmanResult | None, fdir: Path, short: bool, alpha: float,
             registry: Any) -> dict[str, Path | str]:
    """Draw every figure; a value is the PNG path or why the figure was not drawn."""
    figs: dict[str, Path | str] = {}
    problems = sorted(df["problem"].unique())
    traces = traces_frame(loaded.records, df)
    figs["Convergence"] = figures.convergence(traces, fdir / "convergence.png")
    for p in problems:
        figs[f"Per-run metric, {p}"] = figures.runs_metric(df, p, fdir / f"runs_{p}.png")
        figs[f"Relative errors of the mean vector, {p}"] = figures.rel_error_heatmap(
            meanvec, p, fdir / f"rel_error_{p}.png")
        figs[f"Measured vs fitted signals, best run, {p}"] = _signals_figure(
            df, loaded.records, p, fdir / f"signals_{p}.png", registry)
    if not short:
        for context in sorted(df["context"].unique()):
            ranks = stats.mean_ranks_in_context(df, context)
            title = (f"{context}: mean rank of the per-run metric among all runs; bars join "
                     f"optimizers not significantly different (Mann–Whitney, Holm, α={alpha})")
            figs[f"Critical-difference diagram, {context}"] = figures.cd_diagram(
                ranks, stats.pvalue_matrix(pairs, context), title,
                fdir / f"cd_{figures.slug(context)}.png", alpha)
        if fr is not None and fr.mean_ranks is not None:
            figs["Critical-difference diagram across blocks"] = figures.cd_diagram(
                fr.mean_ranks, fr.nemenyi,
                f"Across {len(fr.blocks)} blocks: mean rank of the median metric; bars join "
                f"optimizers not significantly different (Nemenyi, α={alpha})",
                fdir / "cd_blocks.png", alpha)
    return figs


def build_report(
    paths: Iterable[str | Path],
    out_dir: str | Path,
    *,
    short: bool = False,
    alpha: float = stats.ALPHA,
    baseline: str = tables.BASELINE,
    registry: Any = None,
) -> Report:
    """Read the records below ``paths`` and write the report into ``out_dir``.

    ``short`` (a single job's report) skips the significance tests and the comparison
    figures. ``registry`` (default: the installed plugins) rebuilds the best run's problem
    for the measured-vs-fitted figure. Raises :class:`NoRecordsError` when no readable
    record exists.
    """
    paths = [Path(p) for p in paths]
    out_dir = Path(out_dir)
    loaded = load_records(paths)
    if not loaded.records:
        extra = f" ({len(loaded.skipped)} unreadable)" if loaded.skipped else ""
        raise NoRecordsError(
            f"no run records (records/run-*.json) below {', '.join(map(str, paths))}{extra}"
        )
    df = runs_frame(loaded.records)
    tdir, fdir = out_dir / "tables", out_dir / "figures"
    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    runs_csv = out_dir / "runs.csv"
    df.to_csv(runs_csv, index=False)
    written.append(runs_csv)

    meanvec = tables.mean_vector_table(df)
    st = tables.run_stats_table(df, meanvec)
    kw = stats.kruskal_by_context(df)
    pairs = stats.pairwise_by_context(df, alpha)
    verdicts = tables.baseline_verdicts(st, pairs, baseline)
    st["vs_baseline"] = verdicts
    head = _headline(st, verdicts)
    for table, stem in ((head, "headline"), (st, "run_stats"), (meanvec, "mean_vector"),
                        (kw, "kruskal"), (pairs, "pairwise")):
        if table is not None and not table.empty:
            written += render.write_table(table, tdir, stem)
    fr = None if short else stats.friedman_across_blocks(df, alpha)
    if fr is not None and fr.mean_ranks is not None:
        written += render.write_table(fr.wilcoxon, tdir, "friedman_wilcoxon")

    with warnings.catch_warnings():
        # seaborn 0.13 calls matplotlib APIs that newer matplotlib deprecates: not our news.
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        figs = _figures(df, loaded, meanvec, pairs, fr, fdir, short, alpha, registry)
    skipped = {k: v for k, v in figs.items() if isinstance(v, str)}
    written += [v for v in figs.values() if isinstance(v, Path)]

    lines = ["# vpid-bench report" + (" (single job)" if short else ""), ""]
    lines += _sources_text(paths, loaded, df)
    lines += ["", HOW_TO_READ.format(alpha=alpha), "## Headline", "",
              "Per context, optimizers ranked by the median per-run metric (n = successful "
              "runs).", ""]
    for context, g in head.groupby("context", sort=True):
        lines += [f"### {context}", "", render.markdown(g.drop(columns="context")), ""]
    lines += _mean_vector_md(meanvec)
    lines += ["## Per-run statistics", "",
              "Per-run metric: median, quartiles, IQR, mean, sample sd, best and worst; "
              "objective `f`: median, mean, sd, best, worst; evaluations used; wall time per "
              "run (s, measured on a shared machine: indicative only).", ""]
    show = st.drop(columns=["problem", "optimizer"], errors="ignore")
    lines += [render.markdown(show), ""]
    if not short:
        lines += _tests_md(kw, pairs, fr, alpha)
    lines += ["## Figures", ""]
    for title, v in figs.items():
        if isinstance(v, Path):
            lines += [f"### {title}", "", f"![{title}]({v.relative_to(out_dir).as_posix()})", ""]
        else:
            lines += [f"- {title}: not drawn ({v})."]
    lines += ["", "## Files", "",
              "- `runs.csv`: every run, one row each: `pandas.read_csv('runs.csv')`.",
              "- `tables/`: each table as CSV (full precision) and LaTeX (booktabs).",
              "- `figures/`: the PNG figures above.", ""]
    md = out_dir / "report.md"
    md.write_text("\n".join(lines), encoding="utf-8")
    written.append(md)
    headline = render.terminal(head)
    problems = sorted(df["problem"].unique())
    return Report(out_dir, md, headline, len(loaded.records), problems, written, skipped, loaded)
