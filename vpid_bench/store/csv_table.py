"""A table as CSV at full precision: the one writer of every CSV file vpid-bench makes from
numbers (an archive's ``summary.csv``, the report's ``runs.csv`` and ``tables/*.csv``)."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any


def write_csv(path: Path, headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> Path:
    """``headers`` and ``rows`` as CSV at full precision (NaN and ``None`` as empty cells)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(headers)
        for r in rows:
            w.writerow([_cell(v) for v in r])
    return path


def _cell(v: Any) -> Any:
    """A CSV cell: floats at full precision (``repr``), NaN and ``None`` empty."""
    if v is None or isinstance(v, (bool, str)):
        return "" if v is None else v
    try:
        x = float(v)
    except (TypeError, ValueError):
        return v
    if math.isnan(x):
        return ""
    if x.is_integer() and not isinstance(v, float) and type(v).__name__.startswith(("int", "uint")):
        return int(x)
    return repr(x)
