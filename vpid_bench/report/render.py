"""Table rendering: Markdown (pipe tables), LaTeX (booktabs) and CSV, via tabulate/pandas."""

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


def markdown(df: Any, digits: int = 4) -> str:
    """A GitHub pipe table."""
    from tabulate import tabulate

    if df is None or df.empty:
        return "_(empty)_"
    return tabulate(_cells(df, digits), headers=list(df.columns), tablefmt="github",
                    disable_numparse=True)


def terminal(df: Any, digits: int = 4) -> str:
    """A plain-text table for the terminal."""
    from tabulate import tabulate

    return tabulate(_cells(df, digits), headers=list(df.columns), tablefmt="simple",
                    disable_numparse=True)


def latex(df: Any, digits: int = 4) -> str:
    """A LaTeX table body with booktabs rules (needs ``\\usepackage{booktabs}``)."""
    from tabulate import tabulate

    return tabulate(_cells(df, digits), headers=list(df.columns), tablefmt="latex_booktabs",
                    disable_numparse=True)


def write_table(df: Any, directory: Path, stem: str, digits: int = 4) -> list[Path]:
    """Write ``<stem>.csv`` (full precision) and ``<stem>.tex`` (booktabs) into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    csv = directory / f"{stem}.csv"
    tex = directory / f"{stem}.tex"
    df.to_csv(csv, index=False)
    tex.write_text(latex(df, digits) + "\n", encoding="utf-8")
    return [csv, tex]
