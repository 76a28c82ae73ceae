"""Build a report from the run records below any folders into ``out_dir``: ``report.md``,
``runs.csv``, ``tables/`` (CSV and LaTeX), ``figures/``, ``ioh/`` (IOHprofiler's format) and
the HTML pages. ``out_dir`` is one report, whole (issue 44, N6, N8, N9): built in a hidden
folder that takes its place in one rename (:class:`~vpid_bench.fileio.WholeFolder`), so a
failed, interrupted or concurrent build leaves the old report or a new one, and a link
planted in the old folder is removed, never followed. Stages pass data, never text:
:func:`.compute.compute`, then :func:`_assemble` fills one :class:`~.model.ReportModel`,
which the renderers only format. ``short=True`` (a single job's report) has no tests or
figures and imports neither pandas, matplotlib nor scipy.stats."""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from ..fileio import WholeFolder, write_refused
from ..interrupts import raise_if_swallowed
from ..progress import Stages
from ..store import csv_table, ioh
from ..store.paths import inside, slug
from . import answer, anytime, body, first_screen, outline, rankings, render, tables
from . import suite_scores as ss
from .compute import ReportData, compute
from .core_figures import draw_all
from .forked import run_forked
from .interactive import suite_ecdf_figure
from .load import LoadedRecords, NoRecordsError
from .model import ReportModel, SuiteScores
from .outline import full_report_command
from .plugin_sections import plugin_sections
from .site import check_links
from .site_pages import interactive_figures, write_site
from .styles import of_report

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
    #: one line per problem whose archived runs stand in the report, or were refused
    archive_notes: list[str] = dataclasses.field(default_factory=list)
    #: the HTML site's first page (``index.html``), beside report.md
    index_html: Path | None = None
    #: ``warning:`` lines on the folder replaced (symbolic links it held, removed with it)
    folder_notes: list[str] = dataclasses.field(default_factory=list)

    @property
    def failures(self) -> list[str]:
        """One line per failed job, failed run, unreadable record, failed plugin section,
        bad optimum file or run below its instance's optimum."""
        return self.loaded.failures + self.section_errors + self.optima_errors


#: What a report folder holds at its top, besides its pages (``*.html``), and the outcome a
#: sweep writes beside them (``status.json``).
REPORT_ENTRIES = frozenset({"report.md", "runs.csv", "tables", "figures", ioh.FOLDER, "assets",
                            "status.json"})


def foreign_entries(folder: Path) -> list[str]:
    """The entries of ``folder`` that no report writes, sorted (none for a missing folder):
    a report replaces its folder whole, so it must not be written over one holding anything
    else (a user's files, the records themselves)."""
    try:
        names = os.listdir(folder)
    except (FileNotFoundError, NotADirectoryError):
        return []
    return sorted(n for n in names if n not in REPORT_ENTRIES and not n.endswith(".html"))


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


def build_report(paths: Iterable[str | Path], out_dir: str | Path, *, short: bool = False,
                 alpha: float = ALPHA, baseline: str = tables.BASELINE, registry: Any = None,
                 archive: bool | Path = False, progress: Stages | None = None) -> Report:
    """Read the records below ``paths`` and write the report into ``out_dir``. ``registry``
    (default: the installed plugins) gives the report sections; ``archive``: rank the archived
    built-ins beside these runs (``True``: the shipped archives, or a folder of archives);
    ``progress``: where each stage is said as it starts. Raises :class:`NoRecordsError` when
    no readable record exists, ``OSError`` when the report could not be written (``out_dir``
    then left as it was)."""
    data = compute(paths, short, alpha, baseline, archive, progress)
    out_dir = Path(out_dir)
    whole = WholeFolder(out_dir)
    with whole as new:
        names = _Names(new)
        model, written = _assemble(data, names, registry, progress)
        if progress is not None:
            progress.stage("writing report.md and the site")
        md, site = _render(model, names)
        written += [md, *site]
        # A signal a fork's callbacks swallowed (logging's at-fork lock release, while the
        # figures were drawn in forked processes) ends the command here, old report kept.
        raise_if_swallowed()

    def final(path: Path) -> Path:  # a file's path once the new folder is in place
        return out_dir / Path(path).relative_to(new)

    errors = [e.replace(str(new), str(out_dir)) for e in model.section_errors]
    return Report(out_dir, final(md), first_screen.terminal_text(model.results,
                                                                 answer=model.answer),
                  len(data.loaded.records), data.problems, [final(f) for f in written],
                  {k: v for k, v in model.figs.items() if isinstance(v, str)}, data.loaded,
                  errors, data.optima_errors, data.archive_notes,
                  final(site[0]) if site else None, _link_notes(out_dir, whole.links))


def _link_notes(out_dir: Path, links: list[Path]) -> list[str]:
    """One ``warning:`` line naming the symbolic links the replaced folder held (N6: they
    once gave a 20-line traceback, and a sweep no report at all)."""
    if not links:
        return []
    shown = ", ".join(str(p) for p in links[:3]) + (" ..." if len(links) > 3 else "")
    return [f"warning: {out_dir} held {len(links)} symbolic link(s) ({shown}): removed with "
            "the previous report, never followed (what they point to is untouched)"]


def _assemble(data: ReportData, names: _Names, registry: Any,
              progress: Stages | None = None) -> tuple[ReportModel, list[Path]]:
    """Everything the report says, as one :class:`~.model.ReportModel`, with the files
    written on the way (tables, figures, the IOHprofiler export)."""
    if registry is None:
        from ..plugins import Registry

        registry = Registry()
    out_dir = names.root
    written = _write_tables(data, names)
    model = ReportModel(data, first_screen.results(data), out_dir)
    if not data.short:
        model.figs = draw_all(data, names.file, progress)
        written += ioh.export_ioh(out_dir / ioh.FOLDER, data.loaded.records, data.rows, out_dir)
        model.suite, more = _suite_scores(data, registry, names)
        written += more
    model.sections, model.extra, model.section_errors = plugin_sections(
        registry, data, out_dir, names.claim)
    # the tables that wait for the plugins' columns
    _, _, csv_h, csv_rows = body.headline(data.summary, data.baseline_verdicts, model.extra,
                                          data.baseline)
    stat_keys = list(dict.fromkeys(k for s in data.summary for k in s))
    written += (_table(names, "headline", csv_h, csv_rows)
                + _table(names, "run_stats", stat_keys,
                         [[s.get(k) for k in stat_keys] for s in data.summary]))
    written += [v for v in model.figs.values() if isinstance(v, Path)]
    written += [f for placed in model.sections for f in placed.section.files]
    _add_interactive(model)
    model.answer = answer.derive(data, model.results, model.suite, answer.residual_users(
        registry, data.rows) if model.suite is not None else frozenset())
    return model, written


def _add_interactive(model: ReportModel) -> None:
    """The interactive figures of each context; a failure costs them only, and is said."""
    try:
        model.interactive = interactive_figures(model.data)
    except Exception as exc:  # noqa: BLE001 - a figure's fault costs the figures only
        if write_refused(exc):
            raise
        log.debug("interactive figures failed", exc_info=True)
        model.section_errors.append(f"interactive figures: {type(exc).__name__}: {exc}")


def _render(model: ReportModel, names: _Names) -> tuple[Path, list[Path]]:
    """``report.md`` (:mod:`.outline`) and the HTML site, ``index.html`` first."""
    md = names.claim(names.root / "report.md")
    md.write_text("\n".join(outline.markdown(model)), encoding="utf-8")
    site = write_site(model, names.claim)
    model.section_errors += [f"html: broken link {b}" for b in check_links(
        names.root, [p for p in site if p.suffix == ".html"])]
    return md, site


def _table(names: _Names, stem: str, headers: Sequence[str],
           rows: Sequence[Sequence[Any]]) -> list[Path]:
    return render.write_table(names.file("tables", stem, ".csv"), headers, rows)


class _Tables:
    """Tables planned (each its path claimed in order) and written at once, side by side
    (:func:`.forked.run_forked`: an archive's pairwise tables run to 900 kB of LaTeX)."""

    def __init__(self, names: _Names) -> None:
        self.names, self.planned = names, []

    def __call__(self, stem: str, headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
        self.planned.append((self.names.file("tables", stem, ".csv"), headers, rows))

    def write(self) -> list[Path]:
        done = run_forked([lambda t=t: render.write_table(*t) for t in self.planned])
        return [path for paths in done for path in paths]


def _write_tables(data: ReportData, names: _Names) -> list[Path]:
    """``runs.csv`` and every table that does not wait for the plugins' columns."""
    columns = list(dict.fromkeys(k for r in data.rows for k in r))
    written = [csv_table.write_csv(names.claim(names.root / "runs.csv"), columns,
                                [[r.get(k) for k in columns] for r in data.rows])]
    tables = _Tables(names)
    t = data.tests
    if t is not None:
        for stem, frame in (("kruskal", t.kw), ("pairwise", t.pairs),
                            ("pairwise_search", t.spairs)):
            if not frame.empty:
                tables(stem, *render.frame_rows(frame))
        if t.fr.mean_ranks is not None:
            tables("friedman_wilcoxon", *render.frame_rows(t.fr.wilcoxon))
            tables("nemenyi", *render.frame_rows(t.fr.nemenyi.reset_index(names="optimizer")))
        for what, res in t.by_inst.items():
            if any(r.wilcoxon is not None for r in res.values()):
                import pandas as pd

                tables(f"friedman_instances_{what}", *render.frame_rows(
                    pd.concat([r.wilcoxon.assign(context=c) for c, r in res.items()
                               if r.wilcoxon is not None], ignore_index=True)))
    if data.hits:
        tables("ert", anytime.ERT_HEADERS, anytime.ert_rows(data.hits))
    if data.search:
        keys = ["context", *(k for _, k in rankings.SEARCH_COLUMNS)]
        tables("search_quality", keys, [[s.get(k) for k in keys] for s in data.search])
    return written + tables.write()


def _suite_scores(data: ReportData, registry: Any, names: _Names
                  ) -> tuple[SuiteScores | None, list[Path]]:
    """The scores across the suite (none for fewer than two distinct problems with known
    optima: two population sizes of one problem are one problem), their tables and figure
    (:mod:`.suite_scores`)."""
    facts = ss.context_facts(data.loaded.records, data.rows, ss.family_lookup(registry))
    scored = {h.context for h in data.hits}  # the contexts whose runs know their optima
    if len({r["problem"] for r in data.rows if r["context"] in scored}) < 2:
        return None, []
    rows, notes = ss.score_rows(data.hits, facts)
    ladder = ss.ladder_rows(data.hits, facts)
    written = (_table(names, "suite_scores", ss.HEADERS, rows)
               + _table(names, "budget_ladder", ss.LADDER_HEADERS, ladder))
    fig = ss.figure(data.hits, facts, names.file("figures", "suite_ecdf", ".png"), of_report(data))
    if isinstance(fig, Path):
        written.append(fig)
    return SuiteScores(rows, notes, ladder, fig, suite_ecdf_figure(data.hits, facts)), written
