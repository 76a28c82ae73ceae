"""The published results: Tables II (PS = 20) and III (PS = 30) of Gökdağ (2014) in
``data/paper_tables.csv``, per table and algorithm the mean identified vector (``quantity =
mean``), each parameter's relative error (%) with the NoRE (``eps_percent``), the optimum
values (``algorithm = OV``). Table III's DE2 row is repaired (three lost decimal points, as the
listed means give; its ``note`` says so).
"""

from __future__ import annotations

import csv
import functools
from importlib import resources
from typing import Any

CITATION = (
    'H. Gökdağ, "Vehicle Parameter Identification Using DE Algorithms", JMEST 1(5), 2014, '
    "Tables II (PS = 20) and III (PS = 30)"
)
#: The paper's parameter order (the vehicle problem's unknowns, Eq. 4).
PARAMETERS = ("m", "I", "m1", "m2", "k1", "k2", "c1", "c2", "a1")


def _open_csv() -> Any:
    return resources.files("vpid_vehicle").joinpath("data/paper_tables.csv").open(
        encoding="utf-8"
    )


def paper_table() -> Any:
    """The published tables as a DataFrame (table, ps, algorithm, quantity, parameters, ...)."""
    import pandas as pd

    with _open_csv() as fh:
        df = pd.read_csv(fh)
    df["note"] = df["note"].fillna("")
    return df


@functools.cache
def paper_rows() -> tuple[dict[str, str], ...]:
    """The published tables as plain rows of text, read with the csv module (no pandas)."""
    with _open_csv() as fh:
        return tuple(csv.DictReader(fh))


def published(table: Any, algorithm: str, ps: int) -> dict[str, Any] | None:
    """The paper's mean vector, ε (%) and NoRE of ``algorithm`` at ``ps``, or ``None``."""
    rows = paper_rows() if table is None else table.to_dict("records")
    rows = [r for r in rows if r["algorithm"] == algorithm.upper() and int(r["ps"]) == ps]
    mean = next((r for r in rows if r["quantity"] == "mean"), None)
    eps = next((r for r in rows if r["quantity"] == "eps_percent"), None)
    if mean is None or eps is None:
        return None
    return {
        "table": str(mean["table"]),
        "mean": {p: float(mean[p]) for p in PARAMETERS},
        "eps": {p: float(eps[p]) for p in PARAMETERS},
        "nore": float(eps["nore"]),
        "note": str(mean["note"] or ""),
    }
