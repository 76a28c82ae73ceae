"""The report's sections, registered once, in order: what ``report.md`` holds and which page
of the HTML site shows the same (``index``, ``problem``: each problem's share, or
``protocol``), drawn there by the page's template from the model (``drawn="page"``) or from
the part's own Markdown (``drawn="markdown"``)."""

from __future__ import annotations

import dataclasses
import shlex
from collections.abc import Callable
from pathlib import Path
from typing import Any

from . import body, first_screen
from .render import para
from .safe import escape

#: Where the site shows a part.
PAGES = ("index", "problem", "protocol")


@dataclasses.dataclass(frozen=True)
class Part:
    """One section of the report. ``markdown(model, problem)``: its Markdown lines, for
    ``problem`` only (the problem's page) or, with ``None``, for the whole report."""

    key: str
    page: str
    drawn: str  # "page": drawn by the page's template; "markdown": its Markdown converted
    markdown: Callable[[Any, str | None], list[str]]


def full_report_command(job_dir: str | Path) -> str:
    """The command that builds the full report (figures included) of ``job_dir`` in place."""
    job = Path(job_dir)
    return f"vpid-bench-report {shlex.quote(str(job))} -o {shlex.quote(str(job / 'report'))}"


def _intro(model: Any, _: str | None) -> list[str]:
    data = model.data
    n = len(data.loaded.records)
    n_ok = sum(r["status"] == "ok" for r in data.loaded.records)
    what = (", ".join(escape(p) for p in data.problems) if len(data.problems) <= 4 else
            f"{len(data.problems)} problems")  # named in the table of the answer
    return ["# vpid-bench report" + (" (single job)" if data.short else ""), "",
            para(f"{n} run(s) on {what} ({n_ok} ok, {n - n_ok} failed). The answer first; "
                 f"then, per context, which optimizer, {judged(data)}, and why. How to read "
                 "it, the tests and the sources follow. The same report as browsable pages: "
                 "`index.html`."), ""]


def judged(data: Any) -> str:
    """What the report judges an optimizer by, in words (the truth only where there is one)."""
    no_truth = getattr(data, "no_truth", {})
    if no_truth and all(no_truth.values()):
        return "how well it fits and predicts the record"
    return "how far from the truth" + (" (or, where there is none, how well it fits and "
                                       "predicts the record)" if any(no_truth.values()) else "")


def _archive_notes(model: Any, _: str | None) -> list[str]:
    notes = model.data.archive_notes
    if not notes:
        return []
    return [para("Archived runs, made earlier by the code named beside them and ranked here "
                 "with this report's own runs (`archive=false` leaves them out):"), "",
            *(f"- {escape(n)}" for n in notes), ""]


def _single_job(model: Any, _: str | None) -> list[str]:
    data = model.data
    if not (data.short and len(data.paths) == 1):
        return []
    return [para("A single job's report: statistics, no tests, no figures. The full report "
                 "with figures:"), "", f"    {escape(full_report_command(data.paths[0]))}", ""]


def _tests(model: Any, _: str | None) -> list[str]:
    t = model.data.tests
    if t is None:
        return []
    return body.tests_md(t.kw, t.pairs, t.fr, model.data.alpha, t.by_inst)


def _results(model: Any, problem: str | None) -> list[str]:
    contexts = model.data.contexts if problem is None else model.contexts_of(problem)
    return first_screen.markdown_lines([r for r in model.results if r.context in contexts])


#: The report's sections in the order of report.md: the verdict first, the method after.
PARTS: tuple[Part, ...] = (
    Part("intro", "index", "page", _intro),
    Part("answer", "index", "page",
         lambda model, _: first_screen.answer_markdown(getattr(model, "answer", None))),
    Part("archive_notes", "index", "page", _archive_notes),
    Part("results", "index", "page", _results),
    Part("suite", "index", "page", body.suite_md),
    Part("single_job", "index", "page", _single_job),
    Part("rankings", "problem", "page", body.headline_md),
    Part("sections", "problem", "markdown", body.sections_md),
    Part("stats", "problem", "page", body.stats_md),
    Part("tests", "protocol", "markdown", _tests),
    Part("figures", "problem", "page", body.figures_md),
    Part("how_to_read", "protocol", "markdown", body.how_to_read_md),
    Part("sources", "protocol", "markdown", body.sources_md),
    Part("files", "protocol", "page", body.files_md),
)


def markdown(model: Any) -> list[str]:
    """``report.md``: every part's Markdown, in order."""
    return [line for part in PARTS for line in part.markdown(model, None)]


def shown_as_markdown(model: Any, page: str, problem: str | None = None) -> list[tuple[str, str]]:
    """The parts a site page shows from their Markdown: (key, Markdown text), in order;
    ``problem``: that problem's share (the problem pages)."""
    return [(part.key, text) for part in PARTS if part.page == page and part.drawn == "markdown"
            and (text := "\n".join(part.markdown(model, problem)).strip())]
