"""The floors per estimator a job wrote (``estimators.json``, see
:mod:`vpid_bench.analysis.estimator_floors`), read as untrusted input, and said in words."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..estimators import DESCRIPTION, OBJECTIVES
from ..store.job_files import ESTIMATORS, read_job_json
from .load import first_file_by_context
from .safe import escape


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) \
        and v >= 0


def read_estimator_floors(path: Path) -> tuple[dict[str, Any] | None, str]:
    """A job's ``estimators.json``, checked: ``(data, "")`` or ``(None, why)``."""
    data, why = read_job_json(path)
    if why:
        return None, why
    if not isinstance(data, dict):
        return None, "not a JSON object"
    n = data.get("instances")
    floors = data.get("floors")
    checks = (
        ("metric", isinstance(data.get("metric"), str) and 0 < len(data["metric"]) <= 64,
         "a name"),
        ("instances", isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= 1000,
         "an integer in [1, 1000]"),
        ("chosen", data.get("chosen") in OBJECTIVES, "one of " + ", ".join(OBJECTIVES)),
        ("floors", isinstance(floors, dict) and floors and set(floors) <= set(OBJECTIVES)
         and all(isinstance(v, dict) and _number(v.get("median"))
                 and isinstance(v.get("values"), list) and len(v["values"]) == n
                 and all(_number(x) for x in v["values"]) for v in floors.values()),
         "per objective a median and one value per instance, finite and >= 0"),
    )
    for key, ok, expected in checks:
        if not ok:
            return None, f"field {key}: expected {expected}"
    return data, ""


def by_context(records: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]]
               ) -> dict[str, dict[str, Any]]:
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


