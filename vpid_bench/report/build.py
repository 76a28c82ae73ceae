"""Build a report from run records: tables, tests, figures, plugin sections, ``report.md``.

:func:`build_report` reads the records below any number of job or sweep folders (merged),
and writes into ``out_dir``::

    report.md               the report, figures linked (lines within 120 columns)
    runs.csv                one row per run
    tables/*.csv, *.tex     headline, run_stats, tests, and the tables of plugin sections
    figures/*.png           convergence, per-run metric, error heatmap, CD diagrams, plugins'

One pipeline serves both uses. ``short=True`` is a single job's report: the same headline,
statistics and plugin sections, without significance tests and figures, and without
importing pandas, matplotlib or scipy.stats (so a single job's command stays quick). The
full report converts the same tidy rows into a pandas DataFrame for the tests and figures.

It is honest whatever the numbers: every table says how many runs it rests on, the tests
say when they could not be run, and nothing claims significance that the Holm-corrected
p-values do not show.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import logging
import math
import shlex
import textwrap
import time
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from . import anytime, rankings, render, tables
from .drawing import FigureDrawer, FigureMode
from .load import LoadedRecords, NoRecordsError, load_records, reason, run_rows
from .optima import add_optimum_columns, load_optima
from .render import para
from .safe import UnsafePathError, escape, inside, slug
from .sections import Contribution, HeadlineColumn, ReportContext, Section

__all__ = ["NoRecordsError", "Report", "build_report", "full_report_command"]

log = logging.getLogger(__name__)

#: Significance level after Holm correction (the default of ``--alpha``).
ALPHA = 0.05


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
    section_errors: list[str] = dataclasses.field(default_factory=list)
    optima_errors: list[str] = dataclasses.field(default_factory=list)
    #: Wall seconds of each phase (load, stats, figures_submit, sections, tables_md,
    #: figures_wait, total) and how the figures were drawn ("parallel (N workers)"/"serial").
    timings: dict[str, float] = dataclasses.field(default_factory=dict)
    figures_mode: str = ""

    @property
    def failures(self) -> list[str]:
        """One line per failed job, failed run, unreadable record, failed plugin section,
        bad optimum file or run below its instance's optimum."""
        return self.loaded.failures + self.section_errors + self.optima_errors


def full_report_command(job_dir: str | Path) -> str:
    """The command that builds the full report (figures included) of ``job_dir`` in place."""
    job = Path(job_dir)
    return f"vpid-bench-report {shlex.quote(str(job))} -o {shlex.quote(str(job / 'report'))}"


class _Names:
    """File names claimed in this report: a second file with the same safe name gets
    ``-2``, ``-3``, ... instead of overwriting the first."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.used: set[Path] = set()

    def claim(self, path: Path) -> Path:
        inside(self.root, path)
        stem, suffix, n = path.stem, path.suffix, 1
        while path in self.used:
            n += 1
            path = path.with_name(f"{stem}-{n}{suffix}")
        self.used.add(path)
        return path

    def file(self, kind: str, name: str, suffix: str) -> Path:
        return self.claim(self.root / kind / (slug(name) + suffix))


def sources_lines(paths: Iterable[Path], loaded: LoadedRecords,
                  rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """Where the records came from, what was skipped, which jobs and runs failed."""
    n = len(loaded.records)
    n_ok = sum(r["status"] == "ok" for r in loaded.records)
    lines = [para(f"Built {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M UTC} from {n} run "
                  f"record(s) ({n_ok} ok, {n - n_ok} failed) found in:"), ""]
    lines += [f"- `{escape(p)}`" for p in paths]
    notes = []
    if loaded.duplicates:
        notes.append(f"{loaded.duplicates} duplicate record(s) (same run id) were counted once.")
    for p, why in loaded.skipped:
        notes.append(f"**Skipped unreadable record** `{escape(p)}`: {escape(reason(p, why))}")
    for d, why in loaded.failed_jobs:
        notes.append(f"**Job not ok** `{escape(d)}`: {escape(why)}")
    for r in rows:
        if r["status"] != "ok":
            notes.append(f"**Failed run** {escape(r['algorithm'])} on {escape(r['context'])}, "
                         f"run {escape(r['run_index'])} (seed {escape(r['seed'])}): "
                         f"{escape(r['error'])}")
    if notes:
        lines += ["", "Problems found:", ""]
        lines += [textwrap.fill(f"- {t}", width=render.PROSE_WIDTH,
                                       subsequent_indent="  ", break_long_words=False)
                  for t in notes]
    return lines


HOW_TO_READ = """\
**Metric.** Each problem may report accuracy metrics of an identified vector (`result.metrics`
in the records, e.g. a norm of relative errors against the known truth). Runs are judged by
the problem's first metric where every run of the context has it, otherwise by the best
objective value `f` found. Lower is better for both; the headline names the metric.

**Context.** Optimizers are compared within a context: one problem, one population size `ps`
and one value of every other setting that varies across the records (noise level, noise seed,
budget). Runs of different optimizer seeds are pooled.

**Significance.** Within a context, two-sided pairwise tests, Holm-corrected over the pairs of
that context: the paired Wilcoxon signed-rank test over instances where the runs pair by
instance (run i of every optimizer on the same, distinct instance i), else Mann–Whitney U;
exact or permutation p-values for small samples. "Significant" means `p_holm < {alpha}`; the
`group` letters of each ranking show which optimizers the tests cannot separate. Effect size:
Vargha–Delaney `A12 = P(metric_a > metric_b) + ties/2` (below 0.5: `a` tends to be better).
Across blocks (independent instances or contexts, at least 5): Friedman with a permutation
p-value, Nemenyi post-hoc, pairwise Wilcoxon signed-rank with Holm. With few runs or blocks
the tests have little power: "not significant" is not "equal".

**Search quality.** Where the jobs wrote each instance's optimum (`optima/`), each run is also
judged against the lowest objective its own record allows: `rel_gap = (f_best - f_opt) /
|f_opt|`, the floor (the metric of that optimum) and the distance to it; see `runs.csv`.

**Baseline.** `{baseline}`, when it was run, is the line a useful optimizer must clear
(a significantly lower per-run metric at the same budget)."""


def _verdict_short(v: str) -> str:
    """The headline's compact form of a baseline verdict."""
    for long, short in (("beats it (p_holm=", "yes, p="), ("does not clear it (p_holm=", "no, p="),
                        ("WORSE than it (p_holm=", "WORSE, p=")):
        if v.startswith(long):
            return short + v[len(long):].rstrip(")")
    return v


def _headline(summary: list[dict[str, Any]], verdicts: list[str],
              extra: list[HeadlineColumn], baseline: str
              ) -> tuple[list[str], list[list[Any]], list[str], list[list[Any]]]:
    """(headers, rows) of the headline for Markdown/terminal (compact, in priority order,
    context first) and for the CSV (every column)."""
    any_failed = any(s["n_failed"] for s in summary)
    metric = {s["context"]: s["metric_name"] for s in summary}
    show_f = any(m != "f_best" for m in metric.values())
    has_verdict = any(verdicts)
    md_h = ["context", "rank", "group", "optimizer", "n"] + (["failed"] if any_failed else []) + [
        "metric", "median", "IQR"] + (["median f"] if show_f else []) + [c.name for c in extra] + (
        [f"beats {baseline}?"] if has_verdict else [])
    csv_h = ["context", "rank", "group", "optimizer", "n", "failed", "metric", "median", "q1", "q3",
             "mean", "sd", "best", "worst", "median f"] + [c.name for c in extra] + (
        [f"vs {baseline}"] if has_verdict else [])
    md_rows, csv_rows = [], []
    for s, v in zip(summary, verdicts, strict=True):
        key = (s["context"], s["algorithm"])
        q1, q3 = s.get("q1", math.nan), s.get("q3", math.nan)
        iqr = f"[{render.fmt(q1)}, {render.fmt(q3)}]" if s["n_runs"] else ""
        ex = [c.values.get(key) for c in extra]
        md_rows.append([s["context"], s["rank"], s.get("group", "—"), s["algorithm"], s["n_runs"]]
                       + ([s["n_failed"]] if any_failed else [])
                       + [s["metric_name"], s.get("median"), iqr]
                       + ([s.get("f_median")] if show_f else []) + ex
                       + ([_verdict_short(v)] if has_verdict else []))
        csv_rows.append([s["context"], s["rank"], s.get("group", ""), s["algorithm"], s["n_runs"],
                         s["n_failed"],
                         s["metric_name"]] + [s.get(k) for k in (
                             "median", "q1", "q3", "mean", "sd", "best", "worst", "f_median")]
                        + ex + ([v] if has_verdict else []))
    return md_h, md_rows, csv_h, csv_rows


STATS_MD = [("optimizer", "algorithm"), ("n", "n_runs"), ("median", "median"), ("q1", "q1"),
            ("q3", "q3"), ("mean", "mean"), ("sd", "sd"), ("best", "best"), ("worst", "worst"),
            ("median f", "f_median"), ("best f", "f_best"), ("evaluations", "evaluations_max"),
            ("s/run", "wall_time_mean_s")]


def _by_context(items: Sequence[Mapping[str, Any]]) -> dict[str, list[Mapping[str, Any]]]:
    out: dict[str, list[Mapping[str, Any]]] = {}
    for s in items:
        out.setdefault(s["context"], []).append(s)
    return out


def _stats_md(summary: list[dict[str, Any]]) -> list[str]:
    lines = ["## Per-run statistics", "",
             para("Per context: the per-run metric (median, quartiles, mean, sample sd, best, "
                  "worst), the objective `f` (median, best), the evaluations used and the mean "
                  "wall time per run in seconds (a shared machine: indicative only). Columns "
                  "that do not fit in 120 characters, and more, are in `tables/run_stats.csv`."),
             ""]
    for context, g in _by_context(summary).items():
        lines += [f"### {escape(context)} ({escape(g[0]['metric_name'])})", "",
                  render.markdown([h for h, _ in STATS_MD],
                                  [[s.get(k) for _, k in STATS_MD] for s in g], keep=3), ""]
    return lines


def _friedman_md(fr: Any, label: str, alpha: float, files: str) -> list[str]:
    """One Friedman result (across contexts or over the instances of one context)."""
    if fr.mean_ranks is None:
        return [para(f"{label}: Friedman test {fr.note}."), ""]
    sig = fr.wilcoxon[fr.wilcoxon["significant"]]
    return [para(f"{label}: {len(fr.blocks)} blocks ({fr.kind}); optimizers present in every "
                 f"block: {escape(', '.join(fr.algorithms))}. Friedman χ² = "
                 f"{render.fmt(fr.statistic)}, p = {render.fmt(fr.p)} ({fr.p_method}). "
                 f"{fr.note}"), "",
            para("Mean rank per optimizer (1 = best): " + ", ".join(
                f"{escape(a)} {r:.2f}" for a, r in fr.mean_ranks.items())), "",
            para(f"Pairwise Wilcoxon signed-rank over the blocks, Holm-corrected: {len(sig)} of "
                 f"{len(fr.wilcoxon)} pairs significant (p_holm < {alpha})"
                 + (": " + "; ".join(f"{escape(r.a)} vs {escape(r.b)} (p_holm={r.p_holm:.2g})"
                                     for r in sig.itertuples()) if len(sig) else "")
                 + f". {files}"), ""]


def _tests_md(kw: Any, pairs: Any, fr: Any, alpha: float,
              by_inst: Mapping[str, Mapping[str, Any]] | None = None) -> list[str]:
    lines = ["## Statistical tests", "", "### Kruskal–Wallis per context", "",
             render.markdown(["context", "k", "H", "p", "note"],
                             [[r.context, r.k, r.H, r.p, r.note] for r in kw.itertuples()],
                             keep=2), ""]
    lines += [f"### Pairwise tests on the per-run metric, Holm-corrected within each context "
              f"(significant: p_holm < {alpha})", "",
              para("Where every optimizer ran instance i in run i on instances that differ "
                   "(the runs pair by instance), the paired Wilcoxon signed-rank test over "
                   "the instances; otherwise the Mann–Whitney U test. Small samples get exact "
                   "or permutation p-values (column `p_method`)."), ""]
    if pairs.empty:
        lines += ["No pair to compare.", ""]
    for context, g in pairs.groupby("context", sort=True):
        sig = g[g["significant"]]
        lines += [para(f"{escape(context)} ({escape(g['test'].iloc[0])}): {len(sig)} of "
                       f"{len(g)} pairs differ significantly"
                       + (" (below); every pair, with the statistic, raw p and effect size, "
                          "is in `tables/pairwise.csv`." if len(sig) else
                          "; every pair is in `tables/pairwise.csv`.")), ""]
        if len(sig):
            lines += [render.markdown(
                ["better", "worse", "median better", "median worse", "p_holm", "A12", "effect"],
                [[r.better, r.b if r.better == r.a else r.a,
                  r.median_a if r.better == r.a else r.median_b,
                  r.median_b if r.better == r.a else r.median_a, r.p_holm,
                  r.A12 if r.better == r.a else 1 - r.A12, r.effect]
                 for r in sig.itertuples()], keep=2), ""]
    lines += ["### Friedman across blocks", "",
              para("Blocks must be independent: distinct problems or records. The test, "
                   "Nemenyi's post-hoc test and the block Wilcoxon tests run only with at "
                   "least 5 blocks; the Friedman p-value comes from permuting the optimizers' "
                   "values within each block (exact when feasible)."), ""]
    lines += _friedman_md(fr, "Across contexts", alpha,
                          "All pairs: `tables/friedman_wilcoxon.csv`; Nemenyi p-values: "
                          "`tables/nemenyi.csv`.")
    for what, res in (by_inst or {}).items():
        label = "per-run metric" if what == "metric" else "max(rel_gap, 1e-6)"
        for context, r in res.items():
            lines += _friedman_md(r, f"{escape(context)}, instances as blocks, {label}", alpha,
                                  f"All pairs: `tables/friedman_instances_{what}.csv`.")
    return lines


#: A per-context critical-difference diagram needs this many successful runs per optimizer.
CD_MIN_RUNS = 5
#: The critical-difference diagram across blocks needs this many blocks (contexts).
CD_MIN_BLOCKS = 5


def _submitter(figs: dict[str, str | None], drawer: FigureDrawer) -> Any:
    def draw(title: str, data: Any, func: Any, *args: Any) -> None:
        """Submit ``func(data, *args)``, or keep ``data`` as the reason when it is text."""
        if isinstance(data, str):
            figs[title] = data
            return
        figs[title] = None
        drawer.submit(title, func, data, *args)

    return draw


def _early_figures(df: Any, loaded: LoadedRecords, rows: list[dict[str, Any]], names: _Names,
                   drawer: FigureDrawer, hits: Sequence[Any]
                   ) -> tuple[dict[str, str | None], dict[str, str | None]]:
    """Hand the core figures that need no test result to ``drawer`` at once (the workers
    draw them while this process runs the tests): convergence, per-run metric and error
    heatmap per problem, and the ECDFs. Returns (the first three kinds, the ECDFs), titles
    in report order, each with why it cannot be drawn or ``None`` (submitted under its
    title)."""
    from . import anytime, figures
    from .identifiability import reference_levels
    from .load import trace_sets

    figs: dict[str, str | None] = {}
    draw = _submitter(figs, drawer)
    traces = trace_sets(loaded.records, rows)
    draw("Convergence", figures.convergence_panels(traces, *reference_levels(loaded.records, rows))
         if traces else "no traces in the records", figures.draw_convergence,
         names.file("figures", "convergence", ".png"))
    problems = sorted(df["problem"].unique())
    for p in problems:
        draw(f"Per-run metric, {p}", figures.runs_metric_data(df, p), figures.draw_runs_metric,
             names.file("figures", f"runs_{p}", ".png"))
        draw(f"Median per-run absolute relative error per parameter, {p}",
             figures.error_heatmap_data(df, p), figures.draw_error_heatmap,
             names.file("figures", f"errors_{p}", ".png"))
    ecdfs: dict[str, str | None] = {}
    for context in sorted({h.context for h in hits}):
        title = f"Fixed-target ECDF, {context}"
        ecdfs[title] = None
        drawer.submit(title, anytime.ecdf_figure, [h for h in hits if h.context == context],
                      context, names.file("figures", f"ecdf_{context}", ".png"))
    return figs, ecdfs


def _cd_figures(df: Any, pairs: Any, fr: Any, names: _Names, alpha: float,
                by_inst: Mapping[str, Any] | None, drawer: FigureDrawer
                ) -> dict[str, str | None]:
    """Hand the critical-difference diagrams (they need the tests) to ``drawer``."""
    from . import figures, stats

    figs: dict[str, str | None] = {}
    draw = _submitter(figs, drawer)
    for context in sorted(df["context"].unique()):
        g = df[(df["context"] == context) & (df["status"] == "ok")]
        n = g.groupby("algorithm").size()
        title = f"Critical-difference diagram, {context}"
        if len(n) < 2 or n.min() < CD_MIN_RUNS:
            figs[title] = (f"needs at least 2 optimizers with at least {CD_MIN_RUNS} successful "
                           f"runs each (found {len(n)} optimizer(s), fewest runs {n.min()})")
            continue
        metric = g["metric_name"].iloc[0]
        inst = (by_inst or {}).get(context)
        if inst is not None and inst.mean_ranks is None:
            figs[title] = f"the runs pair by instance and the Friedman test {inst.note}"
            continue
        test = pairs[pairs["context"] == context]["test"].iloc[0]
        draw(title, figures.cd_data(
            inst.mean_ranks if inst is not None else stats.mean_ranks_in_context(df, context),
            stats.pvalue_matrix(pairs, context)), figures.draw_cd,
            f"{context}: bars join optimizers not significantly different "
            f"({test}, Holm, α={alpha})",
            (f"mean rank of each optimizer over the {len(inst.blocks)} instances, by per-run "
             f"{metric} (1 = best)") if inst is not None else
            (f"mean rank of each optimizer's runs among all {len(g)} runs of the context, "
             f"by per-run {metric} (1 = best)"),
            names.file("figures", f"cd_{context}", ".png"), alpha)
    title = "Critical-difference diagram across blocks"
    if fr is None or fr.mean_ranks is None or len(fr.blocks) < CD_MIN_BLOCKS:
        found = 0 if fr is None else len(fr.blocks)
        figs[title] = (f"needs a Friedman test over at least {CD_MIN_BLOCKS} blocks (contexts) "
                       f"with the same optimizers; found {found}")
    else:
        draw(title, figures.cd_data(fr.mean_ranks, fr.nemenyi), figures.draw_cd,
             f"Across {len(fr.blocks)} blocks: bars join optimizers not significantly different "
             f"(Nemenyi, α={alpha})",
             "mean rank of each optimizer's median per-run metric over the blocks (1 = best)",
             names.file("figures", "cd_blocks", ".png"), alpha)
    return figs


def _plugin_sections(registry: Any, rows: list[dict[str, Any]], loaded: LoadedRecords,
                     out_dir: Path, short: bool, alpha: float, names: _Names,
                     drawer: FigureDrawer | None = None
                     ) -> tuple[list[tuple[str, Section]], list[HeadlineColumn], list[str]]:
    """Call the section functions registered for the problems in the rows (their
    :meth:`~.sections.ReportContext.draw_figure` figures go to ``drawer``)."""
    if registry is None:
        from ..plugins import Registry

        registry = Registry()
    by_id = {r["run_id"]: r for r in loaded.records}
    sections: list[tuple[str, Section]] = []
    columns: list[HeadlineColumn] = []
    errors: list[str] = []
    from . import identifiability

    def draw(path: Path, func: Any, args: tuple[Any, ...], kwargs: dict[str, Any]) -> None:
        from .drawing import save_drawn

        assert drawer is not None
        drawer.submit(("section", path), save_drawn, func, path, args, kwargs)

    for problem in sorted({r["problem"] for r in rows}):
        funcs = [("vpid-bench", identifiability.section),  # the core's, for every problem
                 *getattr(registry, "report_sections", {}).get(problem, [])]
        prows = tuple(r for r in rows if r["problem"] == problem)
        ctx = ReportContext(problem=problem, rows=prows,
                            records=tuple(by_id[r["run_id"]] for r in prows),
                            out_dir=out_dir, short=short, alpha=alpha, _claim=names.claim,
                            _draw=draw if drawer is not None else None)
        for plugin, func in funcs:
            try:
                contrib = func(ctx)
                if contrib is None:
                    continue
                if not isinstance(contrib, Contribution):
                    raise TypeError(f"returned {type(contrib).__name__}, not a Contribution")
                for sec in contrib.sections:
                    if not isinstance(sec, Section):
                        raise TypeError(f"a section is a {type(sec).__name__}, not a Section")
                    kept = []
                    for f in sec.files:
                        try:
                            kept.append(inside(out_dir, Path(f)))
                        except UnsafePathError as exc:
                            errors.append(f"report section of plugin {plugin!r}: {exc}")
                    sections.append((plugin, dataclasses.replace(sec, files=tuple(kept))))
                columns += [c for c in contrib.headline if isinstance(c, HeadlineColumn)]
            except Exception as exc:  # a plugin's fault costs its section, not the report
                log.debug("report section failed", exc_info=True)
                errors.append(f"report section of plugin {plugin!r} for problem {problem!r} "
                              f"failed: {type(exc).__name__}: {exc}")
    return sections, columns, errors


def _section_md(section: Section, out_dir: Path) -> list[str]:
    lines = [f"## {escape(section.title)}", ""]
    if section.text:
        lines += [section.text.rstrip(), ""]
    links = []
    for f in section.files:
        rel = Path(f).resolve().relative_to(out_dir.resolve()).as_posix()
        if rel.endswith(".png"):
            lines += [f"![{escape(Path(rel).stem)}]({rel})", ""]
        else:
            links.append(f"`{rel}`")
    if links:
        lines += [para("Files: " + ", ".join(links) + "."), ""]
    return lines


def _set_groups(summary: list[dict[str, Any]], pairs: Any, rank: str, n: str) -> None:
    """Each row's rank group (compact letters from the Holm-corrected pairwise tests)."""
    from .stats import rank_groups

    for context, g in _by_context(summary).items():
        order = [s["algorithm"] for s in sorted((s for s in g if s.get(n)),
                                                key=lambda s: s[rank])]
        letters = rank_groups(pairs, context, order) if order else {}
        for s in g:
            s["group"] = letters.get(s["algorithm"], "—")


def build_report(
    paths: Iterable[str | Path],
    out_dir: str | Path,
    *,
    short: bool = False,
    alpha: float = ALPHA,
    baseline: str = tables.BASELINE,
    registry: Any = None,
    figures: FigureMode = "auto",
    workers: int | None = None,
) -> Report:
    """Read the records below ``paths`` and write the report into ``out_dir``.

    ``short``: a single job's report (no tests, no figures, no pandas). ``registry``
    (default: the installed plugins) provides the problems' report sections. ``figures``:
    how the full report draws its figures: ``"parallel"`` in ``workers`` spawned worker
    processes started at once (they import matplotlib while this process reads the
    records and runs the tests), ``"serial"`` here one after another, ``"auto"`` parallel
    when more than one core is available (:mod:`.drawing`). The files are the same either
    way. Raises :class:`NoRecordsError` when no readable record exists.
    """
    drawer = None if short else FigureDrawer(figures, workers)
    try:
        report = _build(paths, out_dir, short, alpha, baseline, registry, drawer)
    except BaseException:  # an error or an interrupt: no worker is left behind
        if drawer is not None:
            drawer.terminate()
        raise
    if drawer is not None:
        drawer.close()
    return report


def _build(paths: Iterable[str | Path], out_dir: str | Path, short: bool, alpha: float,
           baseline: str, registry: Any, drawer: FigureDrawer | None) -> Report:
    """:func:`build_report` with its figure drawer (``None`` in short mode)."""
    t0 = time.perf_counter()
    timings: dict[str, float] = {}
    since = [t0]

    def lap(name: str) -> None:
        """Add the time since the last lap to phase ``name``."""
        now = time.perf_counter()
        timings[name] = timings.get(name, 0.0) + now - since[0]
        since[0] = now

    paths = [Path(p) for p in paths]
    out_dir = Path(out_dir)
    loaded = load_records(paths)
    if not loaded.records:
        extra = ""
        if loaded.skipped:  # say why, from the first one: e.g. records of an older version
            first, why = loaded.skipped[0]
            extra = (f" ({len(loaded.skipped)} unreadable; {first}: "
                     f"{' '.join(reason(first, why).split())})")
        raise NoRecordsError(
            f"no run records (records/run-*.json) below {', '.join(map(str, paths))}{extra}"
        )
    rows = run_rows(loaded.records)
    lap("load")
    optima = load_optima(paths, loaded.records)
    optima_errors = [f"bad optimum file {p}: {why}" for p, why in optima.skipped]
    optima_errors += add_optimum_columns(rows, loaded.records, optima)
    summary = tables.summarize(rows)
    search = rankings.search_summary(rows)
    hits = anytime.run_hits(loaded.records, rows)
    aucs = anytime.auc_table(hits)
    for s in search:
        s["auc"] = aucs.get((s["context"], s["algorithm"]), math.nan)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = _Names(out_dir)
    written: list[Path] = []
    columns: list[str] = []
    for r in rows:
        columns += [k for k in r if k not in columns]
    written.append(render.write_csv(names.claim(out_dir / "runs.csv"), columns,
                                    [[r.get(k) for k in columns] for r in rows]))

    def table(stem: str, headers: Sequence[str], body: Sequence[Sequence[Any]]) -> None:
        path = names.file("tables", stem, ".csv")
        written.append(render.write_csv(path, headers, body))
        tex = path.with_suffix(".tex")
        tex.write_text(render.latex(headers, body) + "\n", encoding="utf-8")
        written.append(tex)

    df = kw = pairs = fr = spairs = None
    by_inst: dict[str, dict[str, Any]] = {}
    figs: dict[str, Path | str] = {}
    fig_titles: dict[str, str | None] = {}
    lap("tables_md")
    if not short:
        from . import stats
        from .load import runs_frame

        df = runs_frame(rows)
        lap("load")
        assert drawer is not None
        early, ecdfs = _early_figures(df, loaded, rows, names, drawer, hits)
        lap("figures_submit")
        kw = stats.kruskal_by_context(df)
        pairs = stats.pairwise_by_context(df, alpha)
        fr = stats.friedman_across_blocks(df, alpha)
        sdf = rankings.search_test_frame(df)
        sdf = sdf[sdf["context"].isin({s["context"] for s in search})]
        spairs = stats.pairwise_by_context(sdf, alpha, "rel_gap_test")
        by_inst = {"metric": stats.friedman_by_instances(df, alpha),
                   "rel_gap": stats.friedman_by_instances(sdf, alpha, "rel_gap_test")}
        lap("stats")
        fig_titles = {**early, **_cd_figures(df, pairs, fr, names, alpha,
                                             by_inst.get("metric", {}), drawer), **ecdfs}
        lap("figures_submit")
        for stem, t in (("kruskal", kw), ("pairwise", pairs), ("pairwise_search", spairs)):
            if not t.empty:
                table(stem, *render.frame_rows(t))
        if fr.mean_ranks is not None:
            table("friedman_wilcoxon", *render.frame_rows(fr.wilcoxon))
            table("nemenyi", *render.frame_rows(fr.nemenyi.reset_index(names="optimizer")))
        for what, res in by_inst.items():
            if any(r.wilcoxon is not None for r in res.values()):
                import pandas as pd

                table(f"friedman_instances_{what}", *render.frame_rows(pd.concat(
                    [r.wilcoxon.assign(context=c) for c, r in res.items()
                     if r.wilcoxon is not None], ignore_index=True)))
        _set_groups(summary, pairs, "rank", "n_runs")
        _set_groups(search, spairs, "rank", "n")
    if hits:
        table("ert", anytime.ERT_HEADERS, anytime.ert_rows(hits))
    if search:
        keys = ["context", "rank", "group", "algorithm", "n", "reached", "share",
                "rel_gap_median", "floor_median", "to_opt_median", "auc"]
        table("search_quality", keys, [[s.get(k) for k in keys] for s in search])
    verdicts = tables.baseline_verdicts(summary, pairs, baseline)
    for s, v in zip(summary, verdicts, strict=True):
        s[f"vs_{baseline}"] = v
    lap("tables_md")
    sections, extra, section_errors = _plugin_sections(
        registry, rows, loaded, out_dir, short, alpha, names, drawer)
    lap("sections")
    md_h, md_rows, csv_h, csv_rows = _headline(summary, verdicts, extra, baseline)
    table("headline", csv_h, csv_rows)
    stat_keys: list[str] = []
    for s in summary:
        stat_keys += [k for k in s if k not in stat_keys]
    table("run_stats", stat_keys, [[s.get(k) for k in stat_keys] for s in summary])
    if not short:
        from .ioh_export import export_ioh

        written += export_ioh(out_dir / "ioh", loaded.records, rows, out_dir)
        lap("tables_md")
        assert drawer is not None
        drawn = drawer.results()
        lap("figures_wait")
        figs = {t: (why if why is not None else _drawn(drawn.get(t))) for t, why in
                fig_titles.items()}
        sections, failed = _drop_failed_figures(sections, drawn)
        section_errors += failed
    skipped = {k: v for k, v in figs.items() if isinstance(v, str)}
    written += [v for v in figs.values() if isinstance(v, Path)]
    for _, sec in sections:
        written += list(sec.files)

    lines = ["# vpid-bench report" + (" (single job)" if short else ""), ""]
    lines += sources_lines(paths, loaded, rows)
    if short and len(paths) == 1:
        lines += ["", para("A single job's report: statistics, no tests, no figures. The full "
                           "report with figures:"), "",
                  f"    {escape(full_report_command(paths[0]))}"]
    lines += ["", "## How to read this report", "",
              HOW_TO_READ.format(alpha=alpha, baseline=escape(baseline)), "",
              "## Headline", "",
              para("Per context, two rankings. First by the problem's metric: the median "
                   "per-run metric (`n`: successful runs; IQR: its quartiles); every column, "
                   "with more statistics, is in `tables/headline.csv`. Then, where each "
                   "instance's optimum is known, by search quality (`tables/search_quality.csv`"
                   ", anytime AUC included)."), ""]
    if optima_errors:
        lines += [para("Instance optima: " + "; ".join(escape(e) for e in optima_errors)
                       + "."), ""]
    centred = rankings.box_centred(loaded.records, rows)
    for context, idx in _by_context([{"context": r[0], "i": i} for i, r in
                                     enumerate(md_rows)]).items():
        body = [md_rows[x["i"]][1:] for x in idx]
        mrows = [s for s in summary if s["context"] == context]
        mname = mrows[0]["metric_name"]
        lines += [f"### {escape(context)}", "", render.markdown(md_h[1:], body, keep=7), "",
                  para(rankings.headline_groups_note(rankings.test_name(pairs, context),
                                                     alpha)), ""]
        srows = [s for s in search if s["context"] == context]
        lines += rankings.search_lines(context, search, None if short else {
            s["algorithm"]: s.get("group", "—") for s in srows}, mname,
            rankings.test_name(spairs, context))
        lines += [para(rankings.verdict(
            context, mname, [s["algorithm"] for s in mrows if s["n_runs"]],
            None if short else {s["algorithm"]: s.get("group", "") for s in mrows}, srows,
            None if short else {s["algorithm"]: s.get("group", "") for s in srows})), ""]
        why = rankings.disagreement(context, mname, mrows, srows, centred.get(context, False),
                                    None if short else {s["algorithm"]: s.get("group", "")
                                                        for s in mrows})
        if why:
            lines += [para(why), ""]
    for _, sec in sections:
        lines += _section_md(sec, out_dir)
    if section_errors:
        lines += [para("Not built: " + "; ".join(escape(e) for e in section_errors) + "."), ""]
    lines += _stats_md(summary)
    if not short:
        lines += _tests_md(kw, pairs, fr, alpha, by_inst)
        lines += ["## Figures", ""]
        for title, v in figs.items():
            if isinstance(v, Path):
                rel = v.relative_to(out_dir).as_posix()
                lines += [f"### {escape(title)}", "", f"![{escape(title)}]({rel})", ""]
        if skipped:
            lines += [para("Not drawn: " + "; ".join(f"{escape(k)} ({escape(v)})"
                                                     for k, v in skipped.items()) + "."), ""]
    lines += ["## Files", "",
              para("`runs.csv`: every run, one row each (`pandas.read_csv('runs.csv')`). "
                   "`tables/`: each table as CSV (full precision) and LaTeX (booktabs)."
                   + ("" if short else " `figures/`: the PNG figures above.")), ""]
    md = names.claim(out_dir / "report.md")
    md.write_text("\n".join(lines), encoding="utf-8")
    written.append(md)
    headline = render.terminal(md_h, md_rows)
    if search:  # the second ranking, and one verdict sentence per context, on the terminal too
        keys = ["context", "rank", "group", "algorithm", "n", "reached", "rel_gap_median",
                "floor_median"]
        headline += "\n\nBy search quality (reached: runs at their instance's optimum):\n"
        headline += render.terminal(
            ["context", "rank", "group", "optimizer", "n", "reached", "median rel_gap",
             "median floor"], [[s.get(k, "") for k in keys] for s in search])
        verdicts = [line for line in lines if line.startswith("Verdict for ")]
        if verdicts:
            headline += "\n\n" + "\n".join(" ".join(v.split()) for v in verdicts)
    problems = sorted({r["problem"] for r in rows})
    lap("tables_md")
    timings["total"] = time.perf_counter() - t0
    mode = ("" if drawer is None else f"parallel ({drawer.workers} workers)"
            if drawer.mode == "parallel" else "serial")
    return Report(out_dir, md, headline, len(loaded.records), problems, written, skipped,
                  loaded, section_errors, optima_errors, timings, mode)


def _drawn(result: Any) -> Path | str:
    """A figure's result as the report keeps it: its path, or why it is missing."""
    if isinstance(result, Path):
        return result
    return str(result) if result else "not drawn (no result from the figure worker)"


def _drop_failed_figures(sections: list[tuple[str, Section]], drawn: Mapping[Any, Any]
                         ) -> tuple[list[tuple[str, Section]], list[str]]:
    """Sections without the figures their :meth:`~.sections.ReportContext.draw_figure`
    failed to draw, and one line per such figure."""
    errors, out = [], []
    for plugin, sec in sections:
        kept = []
        for f in sec.files:
            result = drawn.get(("section", Path(f)), Path(f))
            if isinstance(result, Path):
                kept.append(f)
            else:
                errors.append(f"report section of plugin {plugin!r}: figure "
                              f"{Path(f).name} {result}")
        out.append((plugin, dataclasses.replace(sec, files=tuple(kept))))
    return out, errors
