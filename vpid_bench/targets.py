"""Stop at the final target (the job key ``target``), as COCO does.

A run may end before its budget once it is within the final target of its instance's optimum,
but only where that optimum is known *in advance*: the archive of the problem's suite ships
each instance's optimum (``optima.jsonl``: the value, the vector, and how many polished
starts found it). A run of instance ``i`` then stops after the batch whose best value is at
most ``f_opt + target * |f_opt|`` (``target`` itself where ``f_opt`` is 0), recorded as
``stopped_by: "target"``.

The fixed-target results (hits, ECDF, ERT, AUC) are unchanged by the stop: the report's
targets (relative gaps 1 to 1e-6) are all hit before a final target of 1e-8 is. What changes
is what a fixed-budget column means: ``evaluations`` are those used until the stop, and
``f_best`` and the metrics are those at the stop (within ``target`` of the optimum's).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from .errors import ConfigError
from .problem import Problem
from .spec import Job


def stop_value(f_opt: float, target: float) -> float:
    """The objective value at which a run stops: ``f_opt + target |f_opt|`` (``target``
    where ``f_opt`` is 0, where no relative gap exists)."""
    return f_opt + target * abs(f_opt) if f_opt != 0 else target


def certified_optima(job: Job, problem: Problem, root: Path | None = None) -> dict[int, Any]:
    """Per run index of ``job``, the optimum of its instance found in the archives below
    ``root`` (default: those shipped with the package), matched as the report matches an
    optimum file (problem, instance id, data settings, dimension); runs without one are
    left out."""
    from .report.archive import load_all
    from .report.optima import OptimaIndex, match_optimum

    archives, _ = load_all(root, {job.problem_name})  # an unusable archive certifies nothing
    optima = [o for a in archives for o in a.optima if o.problem == job.problem_name]
    index = OptimaIndex(optima, [])
    names = [""] * problem.bounds.dim
    found = {}
    for i in range(job.spec.runs):
        record = {"problem": {"name": job.problem_name, "config": job.problem_settings()},
                  "instance": {"id": problem.instance(i).instance_id()},
                  "parameters": {"names": names}}
        opt = match_optimum(record, index)
        if opt is not None:
            found[i] = opt
    return found


def with_stops(job: Job, problem: Problem, root: Path | None = None) -> Job:
    """``job`` with the stopping value of each run (``job.stop_at``) when its ``target`` is
    set. Raises :class:`ConfigError` naming the first run whose instance has no optimum
    certified in advance."""
    target = job.spec.target
    if target is None:
        return job
    optima = certified_optima(job, problem, root)
    missing = [i for i in range(job.spec.runs) if i not in optima]
    if missing:
        have = len(optima)
        raise ConfigError(
            "target", target,
            f"runs whose instance optimum is certified in advance: {job.problem_name} run "
            f"{missing[0]} (instance {problem.instance(missing[0]).instance_id()}) has none "
            f"in the archives ({have} of {job.spec.runs} runs have one; the archives ship "
            "the optima of their suite's problems at the default settings, docs/protocol.md)")
    stops = {i: stop_value(o.f_opt, target) for i, o in optima.items()}
    if not all(math.isfinite(v) for v in stops.values()):
        raise ConfigError("target", target, "a target that gives finite stopping values")
    return dataclasses.replace(job, stop_at=stops)
