"""The floors per estimator a job wrote (``estimators.json``, checked by
:func:`vpid_bench.store.job_checks.read_estimator_floors`), said in words."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..estimators import DESCRIPTION, OBJECTIVES
from ..store.job_checks import read_estimator_floors
from ..store.job_files import ESTIMATORS
from .load import Rows, first_file_by_context
from .safe import escape


def by_context(records: Rows, rows: Rows) -> dict[str, dict[str, Any]]:
    """Per context, the first readable ``estimators.json`` of its jobs."""
    return first_file_by_context(records, rows, ESTIMATORS,
                                 lambda path, _rec: read_estimator_floors(path)[0])


def sentence(data: Mapping[str, Any], unit: str, fmt: Any) -> str:
    """``"median rel_error of each estimator's optimum on the first 5 instance(s): ordinary least
    squares (objective=ols) 27.1 %; ..."`` (the objectives of :data:`OBJECTIVES` it has)."""
    floors = data["floors"]
    parts = [f"{DESCRIPTION[o]} (objective={o}) {fmt(floors[o]['median'], 3)} {escape(unit)}"
             .rstrip() for o in OBJECTIVES if floors.get(o) is not None]
    return (f"median {escape(data['metric'])} of each estimator's optimum on the first "
            f"{data['instances']} instance(s): " + "; ".join(parts))


