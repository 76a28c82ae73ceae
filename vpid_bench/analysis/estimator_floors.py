"""Floors per estimator: where each objective's optimum of the same records lies.

A problem that offers the choice of estimator has a Config field ``objective`` taking the
values of :data:`vpid_bench.estimators.OBJECTIVES`. The job polishes, on its first
:data:`INSTANCES` instances, every objective's optimum from the truth and records its headline
metric: what Eq. 3, least squares and the likelihood allow, beside the Cramér–Rao bound. An
objective the problem refuses (``ml`` without noise) is left out.
"""

from __future__ import annotations

import dataclasses
import statistics
from typing import Any

from ..errors import VpidBenchError
from ..estimators import OBJECTIVES
from ..problem import Problem, kept_instance
from ..store.job_files import ESTIMATORS
from .optimum import polish

#: The instances each objective's optimum is polished on (0 .. INSTANCES - 1, at most the
#: job's runs): a few polishes per objective keep the job's analysis short.
INSTANCES = 5
FILE = ESTIMATORS


def truth_optima_metric(problem: Problem, n: int) -> tuple[str, list[float]] | None:
    """The problem's first metric at the optimum of each of instances 0 .. n-1 polished
    from the truth (its objective's floor there); ``None`` without a metric."""
    metric: str | None = None
    values = []
    for i in range(n):
        inst = kept_instance(problem, i)
        metrics = inst.metrics(polish(inst, inst.x_true)[0])
        metric = metric or next(iter(metrics), None)
        if metric is None:
            return None
        values.append(float(metrics[metric]))
    return (metric, values) if metric is not None else None


def estimator_floors(problem: Problem, runs: int) -> dict[str, Any] | None:
    """``{"metric", "instances", "chosen", "floors": {objective: {"median", "values"}}}`` for
    a problem that offers the choice and knows its truth; ``None`` otherwise."""
    config = getattr(problem, "config", None)  # offers the choice: a built-in objective field
    if not (dataclasses.is_dataclass(config) and not isinstance(config, type)
            and getattr(config, "objective", None) in OBJECTIVES) or problem.x_true is None:
        return None
    n = max(1, min(INSTANCES, runs))
    metric: str | None = None
    floors: dict[str, Any] = {}
    for objective in OBJECTIVES:
        try:
            config = dataclasses.replace(problem.config, objective=objective)
            base = problem if objective == problem.config.objective else type(problem)(config)
        except (VpidBenchError, TypeError, ValueError):
            continue  # the problem refuses this objective here (e.g. ml without noise)
        measured = truth_optima_metric(base, n)
        if measured is None:
            return None
        metric, values = measured
        floors[objective] = {"median": statistics.median(values), "values": values}
    if not floors or metric is None:
        return None
    return {"metric": metric, "instances": n, "chosen": problem.config.objective, "floors": floors}
