"""The API through which a problem plugin adds its own sections to the report.

A plugin implements the hook ``vpid_bench_register_report_sections(register)`` and calls
``register("<problem name>", section_function)``. When a report holds runs of that problem,
``section_function(ctx)`` is called with a :class:`ReportContext` and returns a
:class:`Contribution` (or ``None``)::

    from vpid_bench import hookimpl
    from vpid_bench.report.sections import Contribution, HeadlineColumn, Section

    def my_section(ctx):
        rows = [[r["algorithm"], r["f_best"]] for r in ctx.rows if r["status"] == "ok"]
        files = ctx.write_table("my_table", ["algorithm", "f"], rows)
        text = ctx.markdown_table(["algorithm", "f"], rows)
        best = {(r["context"], r["algorithm"]): r["f_best"] for r in ctx.rows}
        return Contribution(sections=(Section("My problem's table", text, tuple(files)),),
                            headline=(HeadlineColumn("my f", best),))

    @hookimpl
    def vpid_bench_register_report_sections(register):
        register("my_problem", my_section)

Rules the report enforces: files must be written with the context's helpers (they land in
``tables/`` and ``figures/`` under names made safe by :func:`.safe.slug`; a returned file
outside the report folder is dropped), record text placed in Markdown should go through
:meth:`ReportContext.escape`, and an exception in a section function costs that section
only (the report says so in one line). In short mode (a single job's report) a section
should skip figures and anything costly.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..store import csv_table
from ..store.paths import inside, slug
from . import render
from .safe import escape


@dataclasses.dataclass(frozen=True)
class Section:
    """One part of ``report.md``: a ``## title``, Markdown ``text`` (keep lines within 120
    characters; a link, image or raw HTML in it is shown as text, :func:`.safe.inert_markdown`)
    and the ``files`` written for it (PNG figures are shown under the text, other files
    linked: the report's own links are the only links)."""

    title: str
    text: str = ""
    files: tuple[Path, ...] = ()


@dataclasses.dataclass(frozen=True)
class HeadlineColumn:
    """An extra column of the headline: ``values[(context, algorithm)]`` (a number or short
    text; a missing key is an empty cell). Keep ``name`` short: the headline must fit in 120
    columns (columns that do not fit are left out of report.md, never out of the CSV)."""

    name: str
    values: Mapping[tuple[str, str], Any]


@dataclasses.dataclass(frozen=True)
class Contribution:
    """What a section function returns."""

    sections: tuple[Section, ...] = ()
    headline: tuple[HeadlineColumn, ...] = ()


@dataclasses.dataclass(frozen=True)
class ReportContext:
    """What a section function may read and the helpers it writes with (read-only).

    ``problem``: the problem name the function was registered for. ``rows``: the tidy runs
    of that problem (one mapping per run, the columns of ``runs.csv``: ``context``,
    ``algorithm``, ``optimizer``, ``ps``, ``status``, ``f_best``, ``metric``, ``metric_name``,
    ``metric.<name>``, ``x.<param>``, ``eps.<param>`` (%), ``true.<param>``, ``run_id``, ...).
    ``records``: the run records of those rows, parsed JSON, same order (do not modify).
    ``out_dir``: the report folder. ``short``: a single job's report (no figures, no
    tests). ``alpha``: the significance level.
    """

    problem: str
    rows: tuple[Mapping[str, Any], ...]
    records: tuple[Mapping[str, Any], ...]
    out_dir: Path
    short: bool
    alpha: float
    _claim: Callable[[Path], Path] = dataclasses.field(repr=False, default=lambda p: p)

    @property
    def contexts(self) -> list[str]:
        """The contexts of this problem's runs, sorted."""
        return sorted({str(r["context"]) for r in self.rows})

    def job_dir(self, record: Mapping[str, Any]) -> Path:
        """The job folder a record was read from (where the job's artifacts are)."""
        return Path(str(record.get("_job_dir", ".")))

    def path(self, kind: str, name: str, suffix: str) -> Path:
        """A new file ``<out_dir>/<kind>/<slug(name)><suffix>`` (``kind``: ``tables`` or
        ``figures``), checked to lie inside the report folder, made unique within this
        report (``-2``, ``-3``, ... when the safe name is taken)."""
        if kind not in ("tables", "figures"):
            raise ValueError(f"kind must be 'tables' or 'figures', not {kind!r}")
        if not re.fullmatch(r"\.[A-Za-z0-9]{1,8}", suffix):
            raise ValueError(f"suffix must look like '.csv' or '.png', not {suffix!r}")
        path = inside(self.out_dir, self.out_dir / kind / (slug(name) + suffix))
        return self._claim(path)

    def write_table(self, name: str, headers: Sequence[str],
                    rows: Sequence[Sequence[Any]]) -> list[Path]:
        """Write ``tables/<name>.csv`` (full precision) and ``.tex`` (booktabs)."""
        csv_path = self.path("tables", name, ".csv")
        tex = csv_path.with_suffix(".tex")
        csv_table.write_csv(csv_path, headers, rows)
        tex.write_text(render.latex(headers, rows) + "\n", encoding="utf-8")
        return [csv_path, tex]

    def save_figure(self, fig: Any, name: str) -> Path:
        """Save a matplotlib figure as ``figures/<name>.png``, close it, and return the path
        (the one way a section draws a figure: build it with matplotlib, hand it here)."""
        from .figures import save

        return save(fig, self.path("figures", name, ".png"))

    @staticmethod
    def markdown_table(headers: Sequence[str], rows: Sequence[Sequence[Any]],
                       keep: int | None = None, digits: int = 4) -> str:
        """A Markdown table within 120 columns, numbers to ``digits`` significant figures
        (see :func:`.render.markdown`)."""
        return render.markdown(headers, rows, keep=keep, digits=digits)

    @staticmethod
    def escape(text: Any) -> str:
        """Record text made safe for a Markdown line or cell."""
        return escape(text)

    @staticmethod
    def para(text: str) -> str:
        """A prose paragraph wrapped at 100 columns."""
        return render.para(text)

    @staticmethod
    def fmt(value: Any, digits: int = 4) -> str:
        """One number as text (``digits`` significant figures)."""
        return render.fmt(value, digits)

