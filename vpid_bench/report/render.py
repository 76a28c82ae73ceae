"""Table rendering: Markdown (pipe tables), LaTeX (booktabs) and CSV, via tabulate/pandas
(:func:`table` and :func:`fmt` need no pandas)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any


def fmt(value: Any, digits: int = 4) -> str:
    """A cell as text: floats to ``digits`` significant figures, NaN as an empty cell."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int,)) and not isinstance(value, bool):
        return str(value)
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    if math.isnan(x):
        return ""
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x.is_integer() and abs(x) < 1e9:
        return str(int(x))
    return f"{x:.{digits}g}"


def _cells(df: Any, digits: int) -> list[list[str]]:
    return [[fmt(v, digits) for v in row] for row in df.itertuples(index=False, name=None)]


def table(headers: list[str], rows: list[list[Any]], tablefmt: str = "github",
          digits: int = 4) -> str:
    """Rows of cells (formatted with :func:`fmt`) as a tabulate table; no pandas needed.
    ``tablefmt``: ``github`` (Markdown), ``simple`` (terminal), ``latex_booktabs``."""
    return _tabulate(headers, [[fmt(v, digits) for v in row] for row in rows], tablefmt)


def _tabulate(headers: list[str], cells: list[list[str]], tablefmt: str) -> str:
    from tabulate import tabulate

    return tabulate(cells, headers=list(headers), tablefmt=tablefmt, disable_numparse=True)


def markdown(df: Any, digits: int = 4) -> str:
    """A GitHub pipe table."""
    if df is None or df.empty:
        return "_(empty)_"
    return _tabulate(list(df.columns), _cells(df, digits), "github")


def terminal(df: Any, digits: int = 4) -> str:
    """A plain-text table for the terminal."""
    return _tabulate(list(df.columns), _cells(df, digits), "simple")


def latex(df: Any, digits: int = 4) -> str:
    """A LaTeX table body with booktabs rules (needs ``\\usepackage{booktabs}``)."""
    return _tabulate(list(df.columns), _cells(df, digits), "latex_booktabs")


def write_table(df: Any, directory: Path, stem: str, digits: int = 4) -> list[Path]:
    """Write ``<stem>.csv`` (full precision) and ``<stem>.tex`` (booktabs) into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    csv = directory / f"{stem}.csv"
    tex = directory / f"{stem}.tex"
    df.to_csv(csv, index=False)
    tex.write_text(latex(df, digits) + "\n", encoding="utf-8")
    return [csv, tex]
