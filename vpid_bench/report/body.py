"""The report's Markdown after its first screen: the rankings in detail, the plugin sections,
the statistics and tests, the figures, how to read the report, where the records came from.
Each function returns Markdown lines from computed data (the parts of :mod:`.outline` take
the :class:`~.model.ReportModel` and the problem whose page shows them, or ``None``); none
reads text written by another."""

from __future__ import annotations

import datetime as _dt
import math
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from . import rankings, render
from .load import by_context, reason
from .render import para
from .safe import escape, inert_markdown
from .sections import HeadlineColumn, Section
from .suite_scores import ladder_table, score_table


def sources_md(model: Any, _: str | None) -> list[str]:
    """Where the records came from, what was skipped, which jobs and runs failed."""
    loaded = model.data.loaded
    n = len(loaded.records)
    n_ok = sum(r["status"] == "ok" for r in loaded.records)
    lines = ["## Sources", "",
             para(f"Built {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M UTC} from {n} run "
                  f"record(s) ({n_ok} ok, {n - n_ok} failed) found in:"), ""]
    lines += [f"- `{escape(p)}`" for p in model.data.paths]
    notes = ([f"{loaded.duplicates} duplicate record(s) (same run id) were counted once."]
             if loaded.duplicates else [])
    notes += [f"**Skipped unreadable record** `{escape(p)}`: {escape(reason(p, why))}"
              for p, why in loaded.skipped]
    notes += [f"**Job not ok** `{escape(d)}`: {escape(why)}" for d, why in loaded.failed_jobs]
    notes += [f"**Failed run** {escape(r['algorithm'])} on {escape(r['context'])}, run "
              f"{escape(r['run_index'])} (seed {escape(r['seed'])}): {escape(r['error'])}"
              for r in model.data.rows if r["status"] != "ok"]
    if notes:
        lines += ["", "Problems found:", ""]
        lines += [textwrap.fill(f"- {t}", width=render.PROSE_WIDTH,
                                       subsequent_indent="  ", break_long_words=False)
                  for t in notes]
    return lines + [""]


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


def how_to_read_md(model: Any, _: str | None) -> list[str]:
    return ["## How to read this report", "", HOW_TO_READ.format(
        alpha=model.data.alpha, baseline=escape(model.data.baseline)), ""]


def verdict_short(v: str) -> str:
    """The headline's compact form of a baseline verdict."""
    for long, short in (("beats it (", "yes, "), ("does not clear it (", "no, "),
                        ("WORSE than it (", "WORSE, ")):
        if v.startswith(long):
            return short + v[len(long):].removesuffix(")").replace("p_holm", "p")
    return v


def headline(summary: list[dict[str, Any]], verdicts: list[str], extra: list[HeadlineColumn],
             baseline: str) -> tuple[list[str], list[list[Any]], list[str], list[list[Any]]]:
    """(headers, rows) of the headline for Markdown/terminal (compact, in priority order,
    context first) and for the CSV (every column)."""
    any_failed = any(s["n_failed"] for s in summary)
    show_f = any(s["metric_name"] != "f_best" for s in summary)
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
                       + ([verdict_short(v)] if has_verdict else []))
        csv_rows.append([s["context"], s["rank"], s.get("group", ""), s["algorithm"], s["n_runs"],
                         s["n_failed"], s["metric_name"]] + [s.get(k) for k in (
                             "median", "q1", "q3", "mean", "sd", "best", "worst", "f_median")]
                        + ex + ([v] if has_verdict else []))
    return md_h, md_rows, csv_h, csv_rows


STATS_MD = [("optimizer", "algorithm"), ("n", "n_runs"), ("median", "median"), ("q1", "q1"),
            ("q3", "q3"), ("mean", "mean"), ("sd", "sd"), ("best", "best"), ("worst", "worst"),
            ("median f", "f_median"), ("best f", "f_best"), ("evaluations", "evaluations_max"),
            ("s/run", "wall_time_mean_s")]


def stats_md(model: Any, problem: str | None) -> list[str]:
    """Per context, the statistics of its runs (of ``problem``'s contexts only, if given)."""
    summary = model.data.summary
    if problem is not None:
        contexts = set(model.contexts_of(problem))
        summary = [s for s in summary if s["context"] in contexts]
    if not summary:
        return []
    lines = ["## Per-run statistics", "",
             para("Per context: the per-run metric (median, quartiles, mean, sample sd, best, "
                  "worst), the objective `f` (median, best), the evaluations used and the mean "
                  "wall time per run in seconds (a shared machine: indicative only). Columns "
                  "that do not fit in 120 characters, and more, are in `tables/run_stats.csv`."),
             ""]
    for context, g in by_context(summary).items():
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
                 f"{render.fmt(fr.statistic)}, {render.p_text(fr.p, fr.p_at_floor)} "
                 f"({fr.p_method}). {fr.note}"), "",
            para("Mean rank per optimizer (1 = best): " + ", ".join(
                f"{escape(a)} {r:.2f}" for a, r in fr.mean_ranks.items())), "",
            para(f"Pairwise Wilcoxon signed-rank over the blocks, Holm-corrected: {len(sig)} of "
                 f"{len(fr.wilcoxon)} pairs significant (p_holm < {alpha})"
                 + (": " + "; ".join(
                     f"{escape(r.a)} vs {escape(r.b)} "
                     f"({render.p_text(r.p_holm, bool(r.p_at_floor), 'p_holm')})"
                     for r in sig.itertuples()) if len(sig) else "")
                 + f". {files}"), ""]


def tests_md(kw: Any, pairs: Any, fr: Any, alpha: float,
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
                  r.median_b if r.better == r.a else r.median_a,
                  render.p_text(r.p_holm, bool(r.p_at_floor), "").lstrip("="),
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


def sections_md(model: Any, problem: str | None) -> list[str]:
    """Every problem's report sections (the core's and the plugins'), then what failed."""
    lines = [line for placed in model.sections if problem in (None, placed.problem)
             for line in section_md(placed.section, model.out_dir)]
    if model.section_errors and problem is None:
        lines += [para("Not built: " + "; ".join(escape(e) for e in model.section_errors)
                       + "."), ""]
    return lines


def section_md(section: Section, out_dir: Path) -> list[str]:
    """A section of a plugin (or of the core) as Markdown: its title and text made inert (a
    link or image in them is text, :func:`.safe.inert_markdown`), then the report's own
    links to the section's files."""
    lines = [f"## {escape(section.title)}", ""]
    if section.text:
        lines += [inert_markdown(section.text).rstrip(), ""]
    links = []
    for f in section.files:
        rel = Path(f).resolve().relative_to(out_dir.resolve()).as_posix()
        if rel.endswith(".png"):
            lines += [f"![{escape(section.title)}: {escape(Path(rel).stem)}]({rel})", ""]
        else:
            links.append(f"[{rel}]({rel})")
    if links:
        lines += [para("Files: " + ", ".join(links) + "."), ""]
    return lines


def headline_md(model: Any, _: str | None) -> list[str]:
    """Both rankings of every context in full (every column; the first screen is a digest),
    with the plugins' headline columns."""
    data = model.data
    md_h, md_rows, _, _ = headline(data.summary, data.baseline_verdicts, model.extra, data.baseline)
    lines = ["## Rankings in detail", "",
             para("Per context, two rankings. First by the problem's metric: the median "
                  "per-run metric (`n`: successful runs; IQR: its quartiles) and the columns "
                  "the problem's plugin adds; every column is in `tables/headline.csv`. Then, "
                  "where each instance's optimum is known, by search quality "
                  "(`tables/search_quality.csv`, anytime AUC included)."), ""]
    if data.optima_errors:
        lines += [para("Instance optima: " + "; ".join(escape(e) for e in data.optima_errors)
                       + "."), ""]
    for context, idx in by_context([{"context": r[0], "i": i}
                                    for i, r in enumerate(md_rows)]).items():
        mrows = data.metric_rows(context)
        mname = mrows[0]["metric_name"]
        lines += [f"### {escape(context)}", "",
                  render.markdown(md_h[1:], [md_rows[x["i"]][1:] for x in idx], keep=7), "",
                  para(rankings.headline_groups_note(data.test_name("metric", context),
                                                     data.alpha)), ""]
        lines += rankings.search_lines(context, data.search, data.groups("search", context),
                                       mname, data.test_name("search", context))
        why = rankings.disagreement(context, mname, mrows, data.search_rows(context),
                                    data.centred.get(context, False),
                                    data.groups("metric", context))
        if why:
            lines += [para(why), ""]
    return lines


def figures_md(model: Any, _: str | None) -> list[str]:
    """The core figures (a full report's), and one line naming those not drawn and why."""
    if model.data.tests is None:
        return []
    figs = model.figs
    lines = ["## Figures", ""]
    for title, v in figs.items():
        if isinstance(v, Path):
            rel = v.relative_to(model.out_dir).as_posix()
            lines += [f"### {escape(title)}", "", f"![{escape(title)}]({rel})", ""]
    skipped = {k: v for k, v in figs.items() if isinstance(v, str)}
    if skipped:
        lines += [para("Not drawn: " + "; ".join(f"{escape(k)} ({escape(v)})"
                                                 for k, v in skipped.items()) + "."), ""]
    return lines


def files_md(model: Any, _: str | None) -> list[str]:
    return ["## Files", "",
            para("`runs.csv`: every run, one row each (`pandas.read_csv('runs.csv')`). "
                 "`tables/`: each table as CSV (full precision) and LaTeX (booktabs)."
                 + ("" if model.data.short else " `figures/`: the PNG figures above.")), ""]


def suite_md(model: Any, _: str | None) -> list[str]:
    """"Across the suite" (:mod:`.suite_scores`): every optimizer's score over all problems,
    the best per family and dimension, the aggregated ECDF figure and the budget ladder."""
    if model.suite is None:
        return []
    rows, fig = model.suite.rows, model.suite.figure
    everything = [r for r in rows if r[0] == "all"]
    if not everything:
        return []
    lines = ["## Across the suite", "",
             para(f"Each optimizer's score over the {everything[0][3]} problems: the mean "
                  "over problems of its fixed-target AUC (relative gaps 1 … 1e-6 to each "
                  "instance's optimum, over log evaluations; 1 = every target at the first "
                  "evaluation), with a 95 % bootstrap interval over runs, and the share of "
                  "(run, target) pairs solved by the end. Each problem weighs the same. Best "
                  "first. `tables/suite_scores.csv` has the groups per family and dimension."),
             "", render.markdown(*score_table(rows)), ""]
    best = []
    for kind in ("family", "dimension"):
        for name in dict.fromkeys(r[1] for r in rows if r[0] == kind):
            top = next(r for r in rows if r[0] == kind and r[1] == name)
            best.append(f"{escape(name)}: {escape(top[2])} ({top[5]:.3f} "
                        f"[{top[6]:.3f}, {top[7]:.3f}])")
    if best:
        lines += [para("Best score per group: " + "; ".join(best) + "."), ""]
    if model.suite.notes:
        lines += [para("Not scored: " + "; ".join(escape(n) for n in model.suite.notes)
                       + "."), ""]
    if isinstance(fig, Path):
        rel = fig.relative_to(model.out_dir).as_posix()
        lines += [f"![Runtime ECDFs aggregated over the suite]({rel})", ""]
    else:
        lines += [para(f"The aggregated ECDF figure was not drawn ({escape(fig)})."), ""]
    return lines + ladder_md(model.suite.ladder, rows)


def ladder_md(rows: Sequence[Sequence[Any]], scores: Sequence[Sequence[Any]] = ()) -> list[str]:
    """The budget ladder (:func:`.suite_scores.ladder_rows`): the share of (run, target) pairs
    solved at 10 to 10,000 evaluations per dimension, read off the same runs, in the order of
    the scores (:func:`.suite_scores.ladder_table`); rungs no run reached are left out."""
    headers, shown = ladder_table(rows, scores)
    if not rows or len(headers) < 2:
        return []
    return ["### The budget ladder", "",
            para("Fixed budgets read off the same runs: the share of (run, target) pairs "
                 "solved within each budget, in evaluations per parameter (D), each problem "
                 "weighing the same; in the order of the scores above. Budgets beyond some "
                 "problem's budget are not shown: those runs did not go that far (`budget=`). "
                 "`tables/budget_ladder.csv`."), "",
            render.markdown(headers, shown), ""]
