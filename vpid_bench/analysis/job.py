"""What a job's records allow: the Cramér–Rao bounds of its design and each instance's
optimum, and the job's search score."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..problem import Problem, offers_residuals
from ..records.io import write_json_atomic
from ..spec import Job


def analyse_job(job: Job, problem: Problem, job_dir: Path, optima_dir: Path,
                records: list[dict[str, Any]]) -> dict[int, float]:
    """For a problem with residuals: each instance's optimum (``optima_dir/<key>.json``,
    shared by the jobs of a sweep; see :mod:`.optimum`), and with a known truth the
    Cramér–Rao bounds of its design (``job_dir/identifiability.json``: instance 0's, and
    under ``instances`` each instance's, :func:`.identifiability.per_instance`) and the
    floors of each estimator where the problem offers the choice (``job_dir/estimators.json``,
    :mod:`.estimator_floors`); without a truth, the profile-likelihood intervals at the
    optimum where they run in reasonable time (``job_dir/profile.json``, :mod:`.estimates`).
    Any problem's fixed comparison rows go to ``job_dir/comparisons.json``. Returns each
    run's relative gap ``(f_best - f*) / f*`` to its instance's optimum (the absolute gap
    where ``f* <= 0``)."""
    from .estimates import write_comparisons

    write_comparisons(problem, job_dir)  # first: cheap, and wanted whatever follows
    if not offers_residuals(type(problem)):
        return {}
    return _residual_analysis(job, problem, job_dir, optima_dir, records)


def _residual_analysis(job: Job, problem: Problem, job_dir: Path, optima_dir: Path,
                       records: list[dict[str, Any]]) -> dict[int, float]:
    """:func:`analyse_job` for a problem with residuals."""
    from .estimates import write_profile
    from .estimator_floors import FILE as FLOORS_FILE
    from .estimator_floors import estimator_floors
    from .identifiability import cramer_rao, per_instance
    from .optimum import update_instance_optimum

    truth = problem.x_true is not None
    target = job_dir / "identifiability.json"
    if truth and not target.is_file():
        crb = cramer_rao(problem)
        if crb is not None:
            crb["instances"] = per_instance(problem, job.spec.runs)
            write_json_atomic(target, crb)
    floors_file = job_dir / FLOORS_FILE
    if truth and not floors_file.is_file():
        floors = estimator_floors(problem, job.spec.runs)
        if floors is not None:
            write_json_atomic(floors_file, floors)
    bests = _run_bests(records)
    by_instance: dict[str | None, tuple[Problem, list, list[int]]] = {}
    for i in range(job.spec.runs):
        inst = problem.instance(i)
        entry = by_instance.setdefault(inst.instance_id(), (inst, [], []))
        entry[1].extend(bests.get(i, []))
        entry[2].append(i)
    gaps: dict[int, float] = {}
    optima = []
    for inst, runs, indices in by_instance.values():
        if not truth and not runs:
            continue  # nothing to start a polish from
        optimum = update_instance_optimum(inst, job.problem_settings(), optima_dir, runs)
        optima.append((inst, optimum))
        f_opt = optimum["f_opt"]
        for i in indices:
            for _, f in bests.get(i, []):
                gaps[i] = (f - f_opt) / f_opt if f_opt > 0 else f - f_opt
    if not truth and optima:
        inst, optimum = min(optima, key=lambda o: o[1]["f_opt"])
        write_profile(inst, optimum, job_dir)
    return gaps


def _run_bests(records: list[dict[str, Any]]) -> dict[int, list[tuple[np.ndarray, float]]]:
    """Each ok run's best vector and value, by run index."""
    bests: dict[int, list[tuple[np.ndarray, float]]] = {}
    for record in records:
        res = record.get("result") or {}
        x, f = res.get("x_best"), res.get("f_best")
        if record["status"] == "ok" and x and None not in x and f is not None:
            bests.setdefault(record["run_index"], []).append((np.asarray(x, float), f))
    return bests


def job_score(gaps: Mapping[int, float], records: list[dict[str, Any]]) -> float | None:
    """The job's search score, lower is better: the median relative gap of the runs' best to
    their instance's optimum where the optimum is known, else the median best objective;
    ``inf`` counts for a failed run. The command returns it, so an optimizing sweeper (Optuna)
    can tune on it."""
    if gaps:
        values = list(gaps.values())
    else:
        values = []
        for record in records:
            f = (record.get("result") or {}).get("f_best")
            values.append(math.inf if record["status"] != "ok" or f is None else float(f))
    return float(np.median(values)) if values else None
