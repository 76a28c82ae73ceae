"""Assembling a run record (schema 2): what a run was, what it found, what produced it.

Each setting is stored once: the problem's (the protocol included) under ``problem.config``,
the optimizer's own under ``optimizer.params``, ``seed`` under ``seeds``, the run's ``budget``
at the top. ``result.intervals`` (no truth, residuals: 95 % intervals of ``x_best``) is absent
otherwise; ``timing`` is the only non-deterministic part.
"""

from __future__ import annotations

import socket
import traceback
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .bounds import relative_errors_percent
from .machine import machine_facts
from .store.provenance import package_versions
from .store.records import SCHEMA

if TYPE_CHECKING:  # the job's types; records sit below the job in the layers
    from .facts import InstanceFacts
    from .job_runs import RunOutcome
    from .spec import Job



def error_section(error: BaseException) -> dict[str, str]:
    """Type, message and traceback of the exception that failed a run."""
    # an exception carried from a worker process keeps its own type name and traceback
    return {"type": getattr(error, "remote_type", type(error).__name__), "message": str(error),
            "traceback": (getattr(error, "remote_traceback", None)
                          or "".join(traceback.format_exception(error)))}


def make_record(job: Job, run: RunOutcome, rid: str, instance: InstanceFacts,
                provenance: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """The one place a run's JSON record is built: ``ok`` with a result, or ``failed`` with
    an error. ``instance``: the facts of the instance it fitted (no problem code runs here);
    ``provenance``: ``{"problem": {...}, "optimizer": {...}}``."""
    b = instance.bounds
    result, error = run.result, run.error
    record: dict[str, Any] = {
        "schema": SCHEMA,
        "run_id": rid,
        "run_index": run.index,
        "status": "ok" if error is None else "failed",
        "error": None if error is None else error_section(error),
        "problem": {"name": job.problem_name, "plugin": dict(provenance.get("problem") or {}),
                    "config": job.problem_settings(), "info": instance.info},
        "optimizer": {"name": job.optimizer_name,
                      "plugin": dict(provenance.get("optimizer") or {}),
                      "params": job.optimizer_settings()},
        "seeds": {"seed": job.spec.seed, "spawn_key": [run.index]},
        "instance": {"index": run.index, "id": instance.id},
        "budget": job.budget,
        "parameters": {"names": list(b.names), "units": list(b.units), "lower": b.lower,
                       "upper": b.upper, "true": instance.x_true},
        "result": None,
        "trace": None,
        "versions": dict(package_versions()),
        "timing": {"started_at": run.started_at, "wall_time_s": run.seconds,
                   "host": socket.gethostname(), "machine": machine_facts()},
    }
    if run.index in job.stop_at:  # stop at the final target (vpid_bench.targets)
        record["target"] = {"gap": job.spec.target, "f_stop": job.stop_at[run.index]}
    if result is not None:  # the loop's own best, what the problem said of it, the truth's
        x_true, derived = instance.x_true, run.derived
        record["result"] = section = {
            "x_best": result.x_best, "f_best": result.f_best, "evaluations": result.evaluations,
            "batches": result.batches, "stopped_by": result.stopped_by,
            "metrics": dict(derived.get("metrics") or {}), "rel_error_percent": None}
        if x_true is not None and np.all(np.isfinite(result.x_best)):
            section["rel_error_percent"] = relative_errors_percent(result.x_best, x_true)
        if "intervals" in derived:  # no truth (job_runs.with_problem_results)
            section["intervals"] = derived["intervals"]
        record["trace"] = {"evaluations": result.trace_evaluations, "best": result.trace_best}
        record["timing"]["run_time_s"] = result.wall_time_s
        # the run's own time at each trace point: wall time to a target (not in the trace,
        # which is deterministic; timing is not)
        record["timing"]["trace_s"] = result.trace_seconds
    return record
