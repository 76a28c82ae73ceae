"""What a job's records allow: the Cramér–Rao bounds of its design and each instance's
optimum, and the job's search score."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .analysis import diagnostics, estimates, estimator_floors, identifiability
from .analysis.optimum import _locked, optimum_key, update_instance_optimum
from .fileio import own_folder
from .problem import Problem, kept_instance, offers_residuals
from .spec import Job
from .store.job_files import ESTIMATORS, IDENTIFIABILITY, read_job_json, write_job_json


def analyse_job(job: Job, problem: Problem, job_dir: Path, optima_dir: Path,
                records: list[dict[str, Any]],
                polished: Mapping[str | None, dict[str, Any]] | None = None
                ) -> dict[int, float]:
    """For a problem with residuals: each instance's optimum (``optima_dir/<key>.json``,
    shared by a sweep's jobs); with a truth, the Cramér–Rao bounds
    (``identifiability.json``) and the floors per estimator (``estimators.json``); without,
    the profile-likelihood intervals (``profile.json``); either way the fit diagnostics and
    both intervals at the optimum (``diagnostics.json``). Any problem's comparison rows go
    to ``comparisons.json``. Returns each run's relative gap ``(f_best - f*) / f*`` to its
    instance's optimum (absolute where ``f* <= 0``). ``polished``: the optima already made
    by :func:`polish_share` tasks, by instance id (nothing is polished here then)."""
    estimates.write_comparisons(problem, job_dir)  # first: cheap, and wanted whatever follows
    if not offers_residuals(type(problem)):
        return {}
    truth = problem.x_true is not None
    if truth and polished is None:
        _per_problem_files(job, problem, job_dir, Path(optima_dir))
    bests = _run_bests(records)
    gaps: dict[int, float] = {}
    optima = []
    for inst, runs, indices in _instances(problem, range(job.spec.runs), bests):
        optimum = (_instance_optimum(job, inst, Path(optima_dir), runs) if polished is None
                   else polished.get(inst.instance_id()))
        if optimum is None:
            continue
        optima.append((inst, optimum))
        f_opt = optimum["f_opt"]
        for i in indices:
            for _, f in bests.get(i, []):
                gaps[i] = (f - f_opt) / f_opt if f_opt > 0 else f - f_opt
    if not getattr(problem, "fits_a_record", True) or not optima:
        return gaps  # no record: no identified value, profile or fit diagnostics
    lowest = min(optima, key=lambda o: o[1]["f_opt"])
    if not truth:
        estimates.write_profile(*lowest, job_dir)
    inst, optimum = optima[0] if truth else lowest  # with a truth: the first instance's
    diagnostics.write_diagnostics(inst, optimum["x_opt"], job_dir)
    return gaps


def polish_share(job: Job, problem: Problem, job_dir: Path, optima_dir: Path,
                 records: list[dict[str, Any]], indices: list[int] | None
                 ) -> dict[str | None, dict[str, Any]]:
    """One worker's share of a job's optimum polishes: the optimum of each instance of runs
    ``indices``, by instance id; or, with ``indices=None``, the per-problem files and ``{}``."""
    if not offers_residuals(type(problem)):
        return {}
    if indices is None:
        if problem.x_true is not None:
            _per_problem_files(job, problem, job_dir, optima_dir)
        return {}
    bests = _run_bests(records)
    return {inst.instance_id(): optimum
            for inst, runs, _ in _instances(problem, indices, bests)
            if (optimum := _instance_optimum(job, inst, optima_dir, runs)) is not None}


def _instances(problem: Problem, indices: Iterable[int],
               bests: Mapping[int, list[tuple[np.ndarray, float]]]
               ) -> list[tuple[Problem, list[tuple[np.ndarray, float]], list[int]]]:
    """The instances of runs ``indices``, each once: ``(instance, its runs' bests, indices)``."""
    by_instance: dict[str | None, tuple[Problem, list, list[int]]] = {}
    for i in indices:
        inst = kept_instance(problem, i)
        entry = by_instance.setdefault(inst.instance_id(), (inst, [], []))
        entry[1].extend(bests.get(i, []))
        entry[2].append(i)
    return list(by_instance.values())


def _instance_optimum(job: Job, inst: Problem, optima_dir: Path,
                      runs: list[tuple[np.ndarray, float]]) -> dict[str, Any] | None:
    """The instance's optimum, polished as far as ``runs`` ask (:mod:`.optimum`); ``None``
    without a truth and without a run to start from."""
    if inst.x_true is None and not runs:
        return None  # nothing to start a polish from
    return update_instance_optimum(inst, job.problem_settings(), optima_dir, runs)


def _per_problem_files(job: Job, problem: Problem, job_dir: Path, optima_dir: Path) -> None:
    """The job's ``identifiability.json`` (instance 0's bounds, each instance's under
    ``instances``) and ``estimators.json``, each made once per sweep (:func:`shared_file`)."""
    runs = job.spec.runs

    def bounds() -> dict[str, Any] | None:
        crb = identifiability.cramer_rao(problem)
        if crb is not None:
            crb["instances"] = identifiability.per_instance(problem, runs)
        return crb

    settings = job.problem_settings()
    n_floors = max(1, min(estimator_floors.INSTANCES, runs))  # what the floors depend on
    for name, make, more in (
            (IDENTIFIABILITY, bounds, runs),
            (ESTIMATORS, lambda: estimator_floors.estimator_floors(problem, runs), n_floors)):
        if not (job_dir / name).is_file():
            data = shared_file(optima_dir, name, problem, settings, more, make)
            if data is not None:
                write_job_json(job_dir / name, data)


#: Where :func:`shared_file` keeps a sweep's per-problem files, inside its optima folder.
SHARED_DIR = "per-problem"


def shared_file(optima_dir: Path, name: str, problem: Problem, settings: Mapping[str, Any],
                more: Any, make: Callable[[], dict[str, Any] | None]) -> dict[str, Any] | None:
    """A per-job file that depends only on the problem's data, made once per sweep: kept in
    ``optima_dir/per-problem/`` by a hash of the problem's name, settings, data digest and
    ``more``, and copied by every later job (a vpid1 build has 19 jobs per problem). A kept
    file that is not a JSON object is made again."""
    key = optimum_key(problem.name, settings, problem.content_digest(), str(more))
    path = own_folder(own_folder(optima_dir) / SHARED_DIR) / f"{Path(name).stem}-{key}.json"
    with _locked(path):  # launcher workers share the folder
        kept = read_job_json(path)[0]
        if isinstance(kept, dict):
            return kept
        data = make()
        if data is not None:
            write_job_json(path, data)
        return data


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
    """The job's search score (what an optimizing sweeper tunes), lower is better: the median
    gap to the instance optima where known, else the median best (``inf``: a failed run)."""
    if gaps:
        values = list(gaps.values())
    else:
        values = []
        for record in records:
            f = (record.get("result") or {}).get("f_best")
            values.append(math.inf if record["status"] != "ok" or f is None else float(f))
    return float(np.median(values)) if values else None
