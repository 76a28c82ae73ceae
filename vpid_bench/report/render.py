"""Tables as text from plain headers and rows: Markdown within 120 columns, terminal, LaTeX
(booktabs). Numbers are formatted per column (:func:`format_column`: integers, fixed point
with one number of decimals, or scientific), so a column never mixes ``14517`` with
``1.513e+04``; record text is escaped (Markdown) or cleaned (terminal)."""

from __future__ import annotations

import math
import re
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..store import csv_table
from .safe import clean, escape, shown

#: The widest line a person reads in ``report.md`` (characters).
MAX_WIDTH = 120
#: Fixed-point columns show at most this many decimals.
MAX_DECIMALS = 4
#: Prose paragraphs are wrapped at this width.
PROSE_WIDTH = 100


def number(value: Any) -> float | None:
    """``value`` as a float when it is a number (not bool), else ``None``."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return None
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def fmt(value: Any, digits: int = 4) -> str:
    """One value as text: ``digits`` significant figures, integers as integers, NaN and
    ``None`` as an empty string, infinities as ``inf``/``-inf``."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    x = number(value)
    if x is None:
        return str(value)
    if math.isnan(x):
        return ""
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x.is_integer() and abs(x) < 1e9:
        return str(int(x))
    return f"{x:.{digits}g}"


def joined(items: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c`` (``""`` for none)."""
    return ", ".join(items[:-1]) + " and " + items[-1] if len(items) > 1 else "".join(items)


def p_text(p: float, bound: bool, name: str = "p") -> str:
    """A p-value as text: ``p=0.012``, or ``p≤0.0002`` where it is a bound."""
    return f"{name}{'≤' if bound else '='}{float(p):.2g}"


def format_column(values: Sequence[Any], digits: int = 4) -> list[str]:
    """Every value of one column in the same number format (see the module docstring)."""
    nums = [number(v) for v in values]
    finite = [x for x in nums if x is not None and math.isfinite(x)]
    if not finite:
        return [fmt(v, digits) for v in values]
    if all(x.is_integer() and abs(x) < 1e9 for x in finite):
        spec = "int"
    else:
        amax = max(abs(x) for x in finite)
        nonzero = [abs(x) for x in finite if x != 0.0]
        amin = min(nonzero) if nonzero else amax
        lead_min = math.floor(math.log10(amin)) if amin > 0 else 0
        lead_max = math.floor(math.log10(amax)) if amax > 0 else 0
        decimals = min(MAX_DECIMALS, max(0, digits - 1 - lead_min))
        # Fixed point when the smallest value keeps `digits` figures and the largest needs
        # at most 8 characters of digits; otherwise scientific for the whole column.
        fixed = amin >= 1e-3 and amax < 1e6 and (lead_max + 1) + decimals <= 8
        spec = f".{decimals}f" if fixed else f".{digits - 1}e"
    return [fmt(v, digits) if x is None or not math.isfinite(x)
            else str(int(x)) if spec == "int" else format(x, spec)
            for v, x in zip(values, nums, strict=True)]


def cells(headers: Sequence[str], rows: Sequence[Sequence[Any]], digits: int = 4
          ) -> list[list[str]]:
    """The rows as text, each column formatted by :func:`format_column`."""
    cols = [format_column([r[j] for r in rows], digits) for j in range(len(headers))]
    return [[cols[j][i] for j in range(len(headers))] for i in range(len(rows))]


def _numeric_columns(rows: Sequence[Sequence[Any]], n: int) -> list[bool]:
    return [bool(rows) and all(number(r[j]) is not None or r[j] is None for r in rows)
            for j in range(n)]


def _pipe(headers: list[str], text: list[list[str]], right: list[bool]) -> str:
    widths = [max([len(h), 3, *(len(r[j]) for r in text)]) for j, h in enumerate(headers)]

    def line(cells_: list[str]) -> str:
        return "| " + " | ".join(
            c.rjust(w) if right[j] else c.ljust(w) for j, (c, w) in enumerate(
                zip(cells_, widths, strict=True))) + " |"

    rule = "|" + "|".join(("-" * (w + 1) + ":") if right[j] else ("-" * (w + 2))
                          for j, w in enumerate(widths)) + "|"
    return "\n".join([line(headers), rule, *(line(r) for r in text)])


_ESCAPE = re.compile(r"\\(.)")


def _shown(cell: str) -> int:
    """The characters of an escaped cell a reader sees (``\\[`` is one): the escapes that
    keep a record's text inert (:func:`.safe.escape`) must not squeeze a table's columns."""
    return len(_ESCAPE.sub(r"\1", cell))


def _width(headers: list[str], text: list[list[str]]) -> int:
    widths = [max([_shown(h), 3, *(_shown(r[j]) for r in text)]) for j, h in enumerate(headers)]
    return sum(widths) + 3 * len(widths) + 1


def _shorten(s: str, n: int) -> str:
    return s if len(s) <= n else s[: max(1, n - 1)] + "…"


def markdown(headers: Sequence[str], rows: Sequence[Sequence[Any]], *, keep: int | None = None,
             max_width: int = MAX_WIDTH, digits: int = 4) -> str:
    """A GitHub pipe table no wider than ``max_width`` as a reader sees it (its source may be
    a few escapes wider): the first ``keep`` columns (default all) always shown, the others
    dropped from the right until it fits, then the longest text cells shortened (with
    ``…``). Text cells and headers are escaped; numbers are aligned right."""
    headers = [escape(h) for h in headers]
    if not rows:
        return "_(empty)_"
    numeric = _numeric_columns(rows, len(headers))
    text = [[escape(c) for c in r] for r in cells(headers, rows, digits)]
    keep = len(headers) if keep is None else max(1, keep)
    cols = list(range(len(headers)))
    while _width([headers[j] for j in cols], [[r[j] for j in cols] for r in text]) > max_width \
            and len(cols) > keep:
        cols.pop()
    h = [headers[j] for j in cols]
    t = [[r[j] for j in cols] for r in text]
    right = [numeric[j] for j in cols]
    limit = max(8, max((len(c) for r in t for c in r), default=8))
    while _width(h, t) > max_width and limit > 8:
        limit -= 1
        t = [[_shorten(c, limit) for c in r] for r in t]
        h = [_shorten(c, max(limit, 8)) for c in h]
    return _pipe(h, t, right)


def terminal(headers: Sequence[str], rows: Sequence[Sequence[Any]], digits: int = 4) -> str:
    """A plain-text table for the terminal: columns two spaces apart, every cell and header one
    printable line (:func:`.safe.clean`), Markdown escapes undone (:func:`.safe.shown`)."""
    headers = [clean(shown(h)) for h in headers]
    text = [[clean(shown(c)) for c in r] for r in cells(headers, rows, digits)]
    numeric = _numeric_columns(rows, len(headers))
    widths = [max([len(h), *(len(r[j]) for r in text)]) for j, h in enumerate(headers)]

    def line(cs: Sequence[str]) -> str:
        return "  ".join(c.rjust(w) if numeric[j] else c.ljust(w)
                         for j, (c, w) in enumerate(zip(cs, widths, strict=True))).rstrip()

    return "\n".join([line(list(headers)), "  ".join("-" * w for w in widths),
                      *(line(r) for r in text)])


def latex(headers: Sequence[str], rows: Sequence[Sequence[Any]], digits: int = 4) -> str:
    """A LaTeX table body with booktabs rules (needs ``\\usepackage{booktabs}``); text
    cells cleaned (:func:`.safe.clean`), as on the terminal."""
    from tabulate import tabulate

    return tabulate([[clean(c) for c in r] for r in cells(headers, rows, digits)],
                    headers=[clean(h) for h in headers],
                    tablefmt="latex_booktabs", disable_numparse=True)


def write_table(path: Path, headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[Path]:
    """``path`` (CSV, full precision) and its ``.tex`` (booktabs)."""
    csv_table.write_csv(path, headers, rows)
    tex = path.with_suffix(".tex")
    tex.write_text(latex(headers, rows) + "\n", encoding="utf-8")
    return [path, tex]


def frame_rows(df: Any) -> tuple[list[str], list[list[Any]]]:
    """A pandas DataFrame as (headers, rows)."""
    return [str(c) for c in df.columns], [list(r) for r in df.itertuples(index=False)]


def para(text: str, width: int = PROSE_WIDTH) -> str:
    """A prose paragraph wrapped at ``width`` (long words, e.g. paths, are not broken)."""
    return textwrap.fill(" ".join(text.split()), width=width, break_long_words=False,
                         break_on_hyphens=False)
