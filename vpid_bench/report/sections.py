"""The API through which a problem plugin adds its own sections to the report (docs/report.md,
"Writing report sections for your problem", has an example): a function registered for a
problem name from ``vpid_bench_register_report_sections`` is called with a
:class:`ReportContext` and returns a :class:`Contribution` (or ``None``). Files are written
with the context's helpers (safe, unique names; a returned file outside the report folder is
dropped), record text in Markdown goes through :meth:`ReportContext.escape`, and an exception
costs that section only. In short mode (a single job's report) a section should skip
figures and anything costly."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..store.paths import inside, slug
from . import render
from .figures import save
from .safe import escape


@dataclasses.dataclass(frozen=True)
class Section:
    """One part of ``report.md``: a ``## title``, Markdown ``text`` (lines within 120
    characters; links, images and HTML in it are shown as text) and its ``files`` (PNGs
    shown under the text, others linked)."""

    title: str
    text: str = ""
    files: tuple[Path, ...] = ()


@dataclasses.dataclass(frozen=True)
class HeadlineColumn:
    """An extra column of the headline: ``values[(context, algorithm)]`` (a missing key is an
    empty cell). Keep ``name`` short: columns past 120 characters stay in the CSV only."""

    name: str
    values: Mapping[tuple[str, str], Any]


@dataclasses.dataclass(frozen=True)
class Contribution:
    """What a section function returns."""

    sections: tuple[Section, ...] = ()
    headline: tuple[HeadlineColumn, ...] = ()


@dataclasses.dataclass(frozen=True)
class ReportContext:
    """What a section function may read and the helpers it writes with (read-only):
    ``rows``, the problem's rows of ``runs.csv`` as mappings; ``records``, their parsed
    records in the same order (do not modify); ``short``: a single job's report."""

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
        ``figures``), inside the report folder, unique within the report (``-2``, ...)."""
        if kind not in ("tables", "figures"):
            raise ValueError(f"kind must be 'tables' or 'figures', not {kind!r}")
        if not re.fullmatch(r"\.[A-Za-z0-9]{1,8}", suffix):
            raise ValueError(f"suffix must look like '.csv' or '.png', not {suffix!r}")
        path = inside(self.out_dir, self.out_dir / kind / (slug(name) + suffix))
        return self._claim(path)

    def write_table(self, name: str, headers: Sequence[str],
                    rows: Sequence[Sequence[Any]]) -> list[Path]:
        """Write ``tables/<name>.csv`` (full precision) and ``.tex`` (booktabs)."""
        return render.write_table(self.path("tables", name, ".csv"), headers, rows)

    def save_figure(self, fig: Any, name: str) -> Path:
        """Save a matplotlib figure as ``figures/<name>.png``, close it, return the path (the
        one way a section adds a figure)."""
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

