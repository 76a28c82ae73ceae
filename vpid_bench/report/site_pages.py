"""The pages of the HTML site (:mod:`.site`), each a pure function from the report's model to
the template's values: the index, one page per problem, one per optimizer, the protocol."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from importlib.resources import files
from pathlib import Path
from typing import Any

from ..store.ioh import FOLDER as IOH_FOLDER
from ..store.paths import slug
from . import answer as answers
from . import body, outline, styles, svg
from .diagnostics import plain_line
from .first_screen import extra_blocks
from .interactive import convergence_figures, ecdf_figure
from .rankings import SEARCH_COLUMNS
from .site import ASSET_DIR, ASSETS, Pages, figure_scope, provenance, relative, render_page, table
from .suite_scores import GROUP_SHOWN, ladder_table, score_table

#: Core figures shown on the index (across problems) rather than on a problem's page.
INDEX_FIGURES = ("Convergence", "Critical-difference diagram across blocks")


def build_pages(model: Any) -> dict[str, str]:
    """Every page of the site: file name -> HTML text, ``index.html`` first."""
    data = model.data
    optimizers = sorted({r["algorithm"] for r in data.rows})
    pages = Pages(data.problems, optimizers)
    common = {
        "prov": provenance(data.loaded), "n_records": len(data.loaded.records),
        "problems": [(p, pages.problem(p)) for p in data.problems],
        "optimizers": [(o, pages.optimizer(o)) for o in optimizers],
    }
    style_of = styles.assign(optimizers)  # the one style per optimizer of every figure
    out = {"index.html": render_page("index.html.j2", page="index", title="Overview",
                                     **common, **_index(model, pages, style_of))}
    for p in data.problems:
        out[pages.problem(p)] = render_page("problem.html.j2", page="problem",
                                            title=f"Problem {p}", name=p, **common,
                                            **_problem(model, pages, p, style_of))
    for o in optimizers:
        out[pages.optimizer(o)] = render_page("optimizer.html.j2", page="optimizer",
                                              title=f"Optimizer {o}", name=o, **common,
                                              **_optimizer(model, pages, o))
    out["protocol.html"] = render_page("protocol.html.j2", page="protocol",
                                       title="Protocol and data", **common,
                                       **_protocol(model))
    return out


def _links(pages: Pages) -> dict[str, Any]:
    return {"optimizer": pages.optimizer, "algorithm": pages.optimizer, "problem": pages.problem}


def _index(model: Any, pages: Pages, style_of: Mapping[str, Any]) -> dict[str, Any]:
    data = model.data
    of = model.problem_of()
    verdicts = [{"name": p, "href": pages.problem(p), "id": "v-" + slug(p), "contexts": [
        {"verdict": r.verdict, "context": r.context, "anchor": _anchor(r.context),
         "n": len(r.rows), "decision": decision(getattr(r, "decision", None), pages),
         "assumed": [text for text, _, _ in getattr(r, "assumed", [])],
         "fit": plain_line(r.diagnostics) if r.diagnostics else "",
         "words": answers.table([r])[1][0][1]} for r in model.results if of.get(r.context) == p]}
        for p in data.problems]
    n_ok = sum(r["status"] == "ok" for r in data.loaded.records)
    short_note = ("A single job's report: statistics, no tests, no figures; "
                  "vpid-bench-report builds the full one." if data.short else "")
    figures = [(relative(v, model.out_dir), k) for k, v in model.figs.items()
               if k in INDEX_FIGURES and isinstance(v, Path)]
    return {"verdicts": verdicts, "n_ok": n_ok, "short": data.short, "figures": figures,
            "archive_notes": data.archive_notes, "suite": _suite(model, pages, style_of),
            "short_note": short_note, "answer": _answer(model, pages),
            "judged": outline.judged(data)}


def _answer(model: Any, pages: Pages) -> dict[str, Any] | None:
    """The answer block of the overview, each context linked to its section."""
    a = getattr(model, "answer", None)
    if a is None:
        return None
    of = model.problem_of()
    links = {"problem": lambda c: pages.problem(c) or _context_href(pages, of, c)}
    return {"sentences": answers.sentences(a),
            "identified": [{"text": text, "table": table(h, rows)}
                           for _, text, h, rows in a.identified],
            "table": table(a.headers, a.rows, links, caption=answers.table_note(a))
            if a.rows else None}


def decision(v: Any, pages: Pages) -> dict[str, Any] | None:
    """The headline of a :class:`.verdicts.Verdict`, names linked to their pages."""
    if v is None or v.kind == "empty":
        return None
    return {"kind": v.kind, "pick": (v.pick, pages.optimizer(v.pick)) if v.pick else None,
            "tied": [(n, pages.optimizer(n)) for n in v.tied],
            "limit": answers.LIMITS.get(v.limit, ""), "not_beaten": list(v.not_beaten),
            "over_bound": v.over_bound}


def _suite(model: Any, pages: Pages, style_of: Mapping[str, Any]) -> dict[str, Any] | None:
    s = model.suite
    if s is None or not s.rows:
        return None
    interactive = None if s.interactive is None else {
        "figure": s.interactive, "id": "fig-suite", "layout": svg.layout(s.interactive, style_of)}
    groups = [row for kind in ("family", "dimension")
              for row in score_table(s.rows, kind)[1]]
    return {"table": table(*score_table(s.rows), _links(pages)), "notes": s.notes,
            "interactive": interactive,
            "ladder": table(*ladder_table(s.ladder, s.rows), _links(pages)) if s.ladder
            else None,
            "groups": table(GROUP_SHOWN, groups, _links(pages)) if groups else None,
            "figure": relative(s.figure, model.out_dir) if isinstance(s.figure, Path) else None}


def _anchor(context: str) -> str:
    """The id of a context's section on its problem's page."""
    return "c-" + slug(context)


def _context_block(model: Any, pages: Pages, r: Any, style_of: Mapping[str, Any],
                   counter: list[int]) -> dict[str, Any]:
    data = model.data
    unit = f" ({r.unit})" if r.unit else ""
    srows = data.search_rows(r.context)
    search = table([h + (unit if k == "floor_median" else "") for h, k in SEARCH_COLUMNS],
                   [[s.get(k) for _, k in SEARCH_COLUMNS] for s in srows],
                   _links(pages)) if srows else None
    stats_rows = data.metric_rows(r.context)
    stats = table([h + (unit if h in ("median", "q1", "q3", "mean", "sd", "best", "worst")
                        else "") for h, _ in body.STATS_MD],
                  [[s.get(k) for _, k in body.STATS_MD] for s in stats_rows], _links(pages),
                  caption=f"Per-run {r.metric}{unit}, objective f, evaluations and seconds "
                  "per run (a shared machine: indicative only)")
    figures = []
    for key in ("ecdf", "convergence"):
        fig = model.interactive.get(r.context, {}).get(key)
        if fig is not None:
            counter[0] += 1
            figures.append((key, {"figure": fig, "layout": svg.layout(fig, style_of),
                                  "id": f"fig{counter[0]}"}))
    extra = [{"text": text, "table": table(h, rows, _links(pages)) if h else None}
             for text, h, rows in extra_blocks(r)]
    return {"context": r.context, "anchor": _anchor(r.context), "verdict": r.verdict,
            "extra": extra,
            "metric": r.metric, "unit": r.unit, "levels": ", ".join(
                f"{what} {r.value(v)}" for what, v in (("floor", r.floor), ("bound", r.bound))
                if math.isfinite(v)),
            "table": table(r.headers, r.rows, _links(pages)), "search": search,
            "stats": stats, "figures": figures}


def _problem(model: Any, pages: Pages, problem: str, style_of: Mapping[str, Any]) -> dict[str, Any]:
    contexts = model.contexts_of(problem)
    counter = [0]
    blocks = [_context_block(model, pages, r, style_of, counter)
              for r in model.results if r.context in contexts]
    names = [problem, *contexts]
    pngs = [(relative(v, model.out_dir), k) for k, v in model.figs.items()
            if isinstance(v, Path) and k not in INDEX_FIGURES and figure_scope(k, names)]
    not_drawn = [f"{k} ({v})" for k, v in model.figs.items()
                 if isinstance(v, str) and figure_scope(k, names)]
    return {"contexts": blocks, "pngs": pngs, "not_drawn": not_drawn,
            "parts": outline.shown_as_markdown(model, "problem", problem)}


OPTIMIZER_HEADERS = ["problem", "context", "rank", "group", "n", "failed", "metric", "unit",
                     "median", "q1", "q3", "search rank", "reached x*", "median rel_gap", "AUC"]


def _optimizer(model: Any, pages: Pages, name: str) -> dict[str, Any]:
    data = model.data
    of = model.problem_of()
    search = {(s["context"], s["algorithm"]): s for s in data.search}
    rows = [[of.get(s["context"], ""), s["context"], s.get("rank"), s.get("group", ""),
             s.get("n_runs"), s.get("n_failed"), s.get("metric_name"), data.unit(s["context"]),
             s.get("median"), s.get("q1"), s.get("q3"), q.get("rank"),
             f"{q['reached']}/{q['n']}" if q else "", q.get("rel_gap_median"), q.get("auc")]
            for s in data.summary if s["algorithm"] == name
            for q in [search.get((s["context"], name), {})]]
    suite = None
    if model.suite is not None and model.suite.rows:
        mine = [row for kind in ("all", "family", "dimension")
                for row in ([["all problems", *r] for r in score_table(model.suite.rows)[1]]
                            if kind == "all" else score_table(model.suite.rows, kind)[1])
                if row[2] == name]
        suite = table(GROUP_SHOWN, mine, _links(pages)) if mine else None
    links = {**_links(pages), "context": lambda c: _context_href(pages, of, c)}
    return {"table": table(OPTIMIZER_HEADERS, rows, links), "suite": suite}


def _context_href(pages: Pages, of: Mapping[str, str], context: str) -> str | None:
    """The link to a context's section on its problem's page."""
    page = pages.problem(of.get(context, ""))
    return f"{page}#{_anchor(context)}" if page else None


def _protocol(model: Any) -> dict[str, Any]:
    data = model.data
    return {"parts": outline.shown_as_markdown(model, "protocol"),
            "archive_notes": data.archive_notes,
            "failures": [*model.section_errors, *data.optima_errors],
            "tables": sorted(p.name for p in (model.out_dir / "tables").glob("*.csv")),
            "ioh": (model.out_dir / IOH_FOLDER).is_dir()}


def interactive_figures(data: Any) -> dict[str, dict[str, Any]]:
    """Per context, its ECDF and convergence figures (:mod:`.interactive`)."""
    conv = convergence_figures(data.loaded.records, data.rows)
    return {c: {"ecdf": ecdf_figure(data.hits, c), "convergence": conv.get(c)}
            for c in data.contexts}


def write_site(model: Any, claim: Callable[[Path], Path]) -> list[Path]:
    """Write the site of ``model`` (a :class:`~.model.ReportModel`) into its report folder;
    return the files written, ``index.html`` first. ``claim`` reserves each file name."""
    out_dir = model.out_dir
    written = []
    for name, text in build_pages(model).items():
        path = claim(out_dir / name)
        path.write_text(text, encoding="utf-8")
        written.append(path)
    (out_dir / ASSET_DIR).mkdir(exist_ok=True)
    for asset in ASSETS:
        path = claim(out_dir / ASSET_DIR / asset)
        path.write_bytes(files("vpid_bench.report").joinpath("templates", asset).read_bytes())
        written.append(path)
    return written

