"""The report as a static HTML site beside ``report.md`` (the overview, a page per problem
and per optimizer, the protocol), rendered from the same model: Jinja2 templates in
auto-escaping, strict mode, every link made by one naming function (:class:`Pages`) and
checked once written. It works from ``file://`` and loads nothing from the network (a small
style sheet and script beside the pages; PNG and inline SVG figures)."""

from __future__ import annotations

import dataclasses
import datetime as _dt
import functools
import math
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..store.paths import slug
from . import render
from .safe import local_link

#: The site's own files, copied from the package beside the pages.
ASSETS = ("report.css", "report.js")
ASSET_DIR = "assets"


@dataclasses.dataclass(frozen=True)
class Cell:
    """A table cell: its text, the raw value it sorts by (``None``: by text), a link."""

    text: str
    sort: str | None = None
    href: str | None = None
    numeric: bool = False


@dataclasses.dataclass(frozen=True)
class Table:
    headers: tuple[str, ...]
    rows: tuple[tuple[Cell, ...], ...]
    caption: str = ""


class Pages:
    """The one naming function of the site: the file of each page, unique per name."""

    def __init__(self, problems: Iterable[str], optimizers: Iterable[str]) -> None:
        used = {"index.html", "protocol.html"}
        self._names: dict[tuple[str, str], str] = {}
        for kind, names in (("problem", problems), ("optimizer", optimizers)):
            for name in sorted(set(names)):
                base, n = f"{kind}-{slug(name)}", 1
                file = f"{base}.html"
                while file in used:
                    n += 1
                    file = f"{base}-{n}.html"
                used.add(file)
                self._names[(kind, name)] = file

    def problem(self, name: str) -> str | None:
        return self._names.get(("problem", name))

    def optimizer(self, name: str) -> str | None:
        return self._names.get(("optimizer", name))


def _sort_value(v: Any) -> str | None:
    """The raw value a numeric cell sorts by (``""`` for a missing number), or ``None``."""
    x = render.number(v)
    if x is None:
        return "" if v is None else None
    return "" if math.isnan(x) else repr(x)


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]],
          links: Mapping[str, Callable[[str], str | None]] | None = None,
          caption: str = "", digits: int = 4) -> Table:
    """A sortable table, numbers as in report.md; cells of the ``links`` columns link to a page."""
    links = links or {}

    def cell(h: str, v: Any, t: str) -> Cell:
        key, link = _sort_value(v), links.get(h)
        return Cell(t, key, link(str(v)) if link and isinstance(v, str) else None, key is not None)

    text = render.cells(headers, rows, digits) if rows else []
    return Table(tuple(headers), tuple(
        tuple(cell(*c) for c in zip(headers, raw, shown, strict=True))
        for raw, shown in zip(rows, text, strict=True)), caption)


@functools.lru_cache(maxsize=1)
def _markdown_parser() -> Any:
    from markdown_it import MarkdownIt

    # raw HTML in a section's text is shown as text, never inserted; a link or image naming
    # anything but a file of the report stays text (the report's own links are the only ones)
    parser = MarkdownIt("commonmark", {"html": False}).enable("table")
    parser.validateLink = local_link
    return parser


def markdown_html(text: str) -> Any:
    """Markdown as HTML: raw HTML escaped, a link or image to anything but a report file as text."""
    from markupsafe import Markup

    return Markup(_markdown_parser().render(text or ""))  # noqa: S704 - escaped by the parser


@functools.lru_cache(maxsize=1)
def environment() -> Any:
    """The Jinja2 environment: templates from the package, auto-escaping, strict undefined."""
    from jinja2 import Environment, PackageLoader, StrictUndefined

    env = Environment(loader=PackageLoader("vpid_bench.report", "templates"),
                      autoescape=True, undefined=StrictUndefined, trim_blocks=True,
                      lstrip_blocks=True, keep_trailing_newline=True)
    env.filters["md"] = markdown_html
    env.filters["fmt"] = render.fmt
    return env


def render_page(template: str, **context: Any) -> str:
    """One page as text (a pure function of its arguments)."""
    return environment().get_template(template).render(**context)


def relative(path: Path, root: Path) -> str:
    return Path(path).resolve().relative_to(root.resolve()).as_posix()


def provenance(loaded: Any) -> dict[str, Any]:
    """Which vpid-bench versions and machines made the records, and which built the site."""
    from .. import __version__

    versions, machines = set(), set()
    for r in loaded.records:
        v = (r.get("versions") or {}).get("vpid-bench")
        if isinstance(v, str):
            versions.add(v[:40])
        m = ((r.get("timing") or {}).get("machine") or {})
        if isinstance(m, Mapping) and isinstance(m.get("cpu"), str):
            machines.add(f"{m['cpu'][:80]}, {m.get('cores')} cores")
    return {"built_by": f"vpid-bench {__version__}",
            "built_at": f"{_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M UTC}",
            "versions": sorted(versions), "machines": sorted(machines)}


def figure_scope(title: str, names: Iterable[str]) -> bool:
    """Whether a figure's title (``"<what>, <problem or context>"``) names one of ``names``."""
    return any(title.endswith(f", {n}") for n in names)


def check_links(out_dir: Path, pages: Iterable[Path]) -> list[str]:
    """What the pages name that is no file of the report (empty: every ``href`` and ``src``
    resolves): the report's own links are the only links."""
    bad = []
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for _tag, _attr, target in re.findall(r'<(\w+)[^>]*?\s(href|src)="([^"#]*)', text):
            if not target:
                continue
            if not local_link(target):
                bad.append(f"{page.name}: {target} (not a file of the report)")
            elif not (page.parent / target).exists():
                bad.append(f"{page.name}: {target}")
    return bad
