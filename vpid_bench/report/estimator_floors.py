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
    """``"on the first 5 instances, the optimum of Eq. 3 lies a median 27.1 % from the
    truth, of least squares 31.4 %, of the likelihood 0.95 %"``."""
    parts = []
    for objective in OBJECTIVES:
        floor = data["floors"].get(objective)
        if floor is not None:
            parts.append(f"{DESCRIPTION[objective]} (objective={objective}) "
                         f"{fmt(floor['median'], 3)} {escape(unit)}".rstrip())
    return (f"median {escape(data['metric'])} of each estimator's optimum on the first "
            f"{data['instances']} instance(s): " + "; ".join(parts))


