"""Stop at the final target (the job key ``target``), as COCO does.

A run may end once within the final target of its instance's optimum, known *in advance*
from the suite's archive (``optima.jsonl``, untrusted: the installed problem must confirm
it). A run then stops after the batch whose best value is at most :func:`stop_value`:
``stopped_by: "target"`` (what stays and what changes in a report: docs/protocol.md).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from .errors import ConfigError
from .problem import Problem, kept_instance
from .spec import Job
from .store.archive_records import load_all
from .store.optimum import OptimaIndex, matching_optima


def stop_value(f_opt: float, target: float) -> float:
    """The objective value at which a run stops: ``f_opt + target |f_opt|`` (``target``
    where ``f_opt`` is 0, where no relative gap exists)."""
    return f_opt + target * abs(f_opt) if f_opt != 0 else target


#: Relative tolerance within which the installed problem's objective at a certified point
#: must give the archived value (and within which two archives' values agree): a batch
#: evaluation may differ from a single one by a few ulps, a changed or forged value by more.
CERTIFY_RTOL = 1e-9


def _close(a: float, b: float) -> bool:
    return math.isfinite(a) and math.isfinite(b) and \
        abs(a - b) <= CERTIFY_RTOL * max(abs(a), abs(b), 1e-12)


def _refused(job: Job, run: int, instance: Problem, why: str) -> ConfigError:
    return ConfigError("target", job.spec.target, f"optima the installed problem confirms: "
                       f"{job.problem_name} run {run} (instance {instance.instance_id()}): "
                       f"{why}; rebuild the archive (tools/build_archive.py, "
                       "docs/protocol.md) or leave target= out")


def _certify(job: Job, run: int, instance: Problem, found: list[Any]) -> Any:
    """The optimum of run ``run``'s instance the archives agree on and the installed problem
    confirms (its value at its point inside the box, no higher than at a known truth): a
    forged ``f_opt`` once stopped every run after a few evaluations."""
    opt = min(found, key=lambda o: o.f_opt)
    for other in found:
        if not _close(other.f_opt, opt.f_opt):
            raise _refused(job, run, instance, f"the archives disagree on its optimum "
                           f"({opt.f_opt:.10g} in {opt.path}, {other.f_opt:.10g} in "
                           f"{other.path})")
    x = np.asarray(opt.x_opt, dtype=float)
    box = instance.bounds
    if not (np.all(x >= box.lower) and np.all(x <= box.upper)):
        raise _refused(job, run, instance, f"its certified point ({opt.path}) lies outside "
                       "the search box")
    f = float(np.asarray(instance.evaluate(x[None, :]), dtype=float).ravel()[0])
    if not _close(f, opt.f_opt):
        raise _refused(job, run, instance, f"the archive gives f_opt {opt.f_opt:.10g} at its "
                       f"point ({opt.path}), the installed problem {f:.10g} there")
    truth = instance.x_true
    if truth is not None:
        f_true = float(np.asarray(instance.evaluate(np.asarray(truth, dtype=float)[None, :]),
                                  dtype=float).ravel()[0])
        if opt.f_opt > f_true and not _close(opt.f_opt, f_true):
            raise _refused(job, run, instance, f"the archive's optimum {opt.f_opt:.10g} "
                           f"({opt.path}) lies above the objective at the truth, {f_true:.10g}")
    return opt


def certified_optima(job: Job, problem: Problem, root: Path | None = None) -> dict[int, Any]:
    """Per run index of ``job``, its instance's optimum in the archives below ``root``,
    matched as the report matches one and confirmed (:func:`_certify`), if any."""
    # an unusable archive certifies nothing; its runs are not needed
    archives, _ = load_all(root, {job.problem_name}, optima_only=True)
    optima = [o for a in archives for o in a.optima if o.problem == job.problem_name]
    index = OptimaIndex(optima, [])
    names = [""] * problem.bounds.dim
    found = {}
    for i in range(job.spec.runs):
        instance = kept_instance(problem, i)
        record = {"problem": {"name": job.problem_name, "config": job.problem_settings()},
                  "instance": {"id": instance.instance_id()},
                  "parameters": {"names": names}}
        matches = matching_optima(record, index)
        if matches:
            found[i] = _certify(job, i, instance, matches)
    return found


def with_stops(job: Job, problem: Problem, root: Path | None = None) -> Job:
    """``job`` with each run's stopping value (``job.stop_at``) when ``target`` is set;
    :class:`ConfigError` names the first run whose instance has no optimum certified."""
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
            f"{missing[0]} (instance {kept_instance(problem, missing[0]).instance_id()}) has none "
            f"in the archives ({have} of {job.spec.runs} runs have one; the archives ship "
            "the optima of their suite's problems at the default settings, docs/protocol.md)")
    stops = {i: stop_value(o.f_opt, target) for i, o in optima.items()}
    if not all(math.isfinite(v) for v in stops.values()):
        raise ConfigError("target", target, "a target that gives finite stopping values")
    return dataclasses.replace(job, stop_at=stops)


def check_sized(job: Job, problem: Problem) -> None:
    """What a job's ``budget_per_dim`` and ``target`` need of its built problem, checked
    (:class:`ConfigError`): the pre-flight's check of every job that sets either."""
    with_stops(job.sized(problem.bounds.dim), problem)
