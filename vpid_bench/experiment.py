"""Run a job: a parsed job spec, the plugin registry and a folder in; run records out.

:func:`run_from_config` is a plain function of a composed config, so tests call it directly;
the command's shell (:mod:`vpid_bench.shell`) calls it once per job.

Seeds: run ``i`` of a job draws its optimizer randomness from
``numpy.random.default_rng(SeedSequence(seed, spawn_key=(i,)))``, the stream
``SeedSequence(seed).spawn(runs)[i]`` gives, so runs are independent and any single run can be
repeated alone.

Resume: a run whose complete record (status ``ok``, same run id) exists in the job folder is
skipped; missing, corrupt and failed runs are run again. The run id hashes everything that
determines a result, the plugins' versions and the content of data files included, so runs
recorded under another plugin release or another data file are run again, never reused.

Crash isolation: an exception (``SystemExit`` included) inside one run is written into that
run's record (status ``failed``) and the job goes on; only ``KeyboardInterrupt`` stops it.

Lockstep: when the problem's values do not depend on the batch
(:attr:`~vpid_bench.api.Problem.rows_independent`) and the optimizer asks and tells in the run
loop's thread (not a :class:`~vpid_bench.api.LoopOptimizer`, no residuals), the runs still to
do advance together (:func:`vpid_bench.runner.run_many`): one evaluation call per step for all
of them, so small populations fill the kernel and its threads. Each run keeps its generator,
budget and trace; its record is bit-identical to the one it gets alone (tested). Its
``timing.wall_time_s`` is its own share: its optimizer's time plus its rows' share of each
gathered evaluation.

Timing: before the first timed run the job makes one untimed warm-up run of at most two
batches, so compiled kernels (numba) are compiled before any run is timed; its cost is the
summary's ``warmup_s``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import logging
import sys
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from . import records as rec
from .api import LoopOptimizer, Optimizer, Problem
from .artifacts import best_of, write_best_signals
from .machine import available_cores
from .plugins import Registry
from .runner import Lane, RunResult, RunTimeoutError, run, run_many
from .spec import Job, parse_job

log = logging.getLogger(__name__)


@dataclasses.dataclass
class JobSummary:
    """What a job did: where, how many runs were run, skipped and failed, and how long."""

    job_dir: Path
    problem: str
    optimizer: str
    runs: int
    ran: int
    skipped: int
    failed: list[int]
    record_paths: list[Path]
    wall_time_s: float
    warmup_s: float = 0.0
    #: The job's search score, lower is better: the median relative gap of the runs' best to
    #: their instance's optimum where the optimum is known, else the median best objective.
    #: The command's task returns it, so an optimizing sweeper (Optuna) can tune on it.
    score: float | None = None


class ProblemCache:
    """Problems built in this process, by (class, name, config).

    The jobs of a sweep that share a problem config (ten optimizers at the same ``ps``) share
    one instance, so a costly set-up (a reference simulation) is done once per process, not
    once per job. ``evaluate`` is a pure function of the config, so this changes no result.
    """

    def __init__(self, size: int = 8) -> None:
        self.size = size
        self._items: dict[Any, Problem] = {}

    def get(self, job: Job) -> Problem:
        """The problem of ``job``, built or re-used."""
        key: Any = (job.problem_cls, job.problem_name, job.problem_config)
        try:
            hash(key)
        except TypeError:  # a config with unhashable values: build it every time
            return build_problem_from_job(job)
        if key not in self._items:
            if len(self._items) >= self.size:
                self._items.pop(next(iter(self._items)))
            self._items[key] = build_problem_from_job(job)
        return self._items[key]


def build_problem_from_job(job: Job) -> Problem:
    """A new problem instance of ``job`` (its plugin's own set-up runs here)."""
    problem = job.problem_cls(job.problem_config)
    problem.name = job.problem_name
    return problem


def build_problem(registry: Registry, cfg: Mapping) -> Problem:
    """The problem named by ``cfg['name']``, built from the rest of ``cfg`` (tests, scripts)."""
    from .params import build_dataclass
    from .spec import check_protocol

    cls = registry.problem(cfg.get("name"))
    config = build_dataclass(cls.Config, cfg, prefix="problem")
    check_protocol(config)
    problem = cls(config)
    problem.name = cfg.get("name")
    return problem


def optimizer_params(registry: Registry, cfg: Mapping) -> tuple[type[Optimizer], Any]:
    """The optimizer class named by ``cfg['name']`` and its validated ``Params`` (the protocol
    keys ``ps``/``iterations`` may be given here: scripts and tests build optimizers alone)."""
    from .params import build_dataclass

    cls = registry.optimizer(cfg.get("name"))
    return cls, build_dataclass(cls.Params, cfg, prefix="optimizer")


def run_rng(seed: int, run_index: int) -> np.random.Generator:
    """The optimizer's random stream of run ``run_index``: child ``run_index`` of ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(run_index,)))


def _existing_ok(path: Path, rid: str) -> bool:
    if not path.is_file():
        return False
    try:
        record = rec.read_record(path)
    except rec.CorruptRecordError as exc:
        log.warning("%s; running it again", exc)
        return False
    return record["run_id"] == rid and record["status"] == "ok"


@contextlib.contextmanager
def _time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`RunTimeoutError` in this thread after ``seconds`` of wall time: the run
    loop's own alarm (POSIX main thread only; elsewhere a warning says it is not applied)."""
    from .runner import _Alarm

    alarm = _Alarm(seconds)
    if seconds is not None and not alarm.enabled:
        log.warning("run_timeout_s needs the main thread of a POSIX process; not applied")
    with alarm, alarm.limit(seconds):
        yield


@contextlib.contextmanager
def _one_blas_thread() -> Iterator[None]:
    """numpy's and scipy's BLAS/OpenMP pools limited to one thread for the job, unless the
    user set a thread count in the environment: a problem's own threads (``threads``) and the
    launcher's workers share the cores, and oversubscribed BLAS threads slow them all down."""
    import os

    if any(os.environ.get(v) for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                       "MKL_NUM_THREADS", "VPID_BENCH_BLAS_THREADS")):
        yield
        return
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def _warm_up(job: Job, problem: Problem, lockstep: bool = False) -> float:
    """One untimed run of at most two batches, so compilation is not timed (see module); in
    lockstep also one gathered call over two instances (its own compiled path)."""
    t0 = time.perf_counter()
    try:
        with _time_limit(job.spec.run_timeout_s):  # a plugin that never returns: bounded here too
            if lockstep:
                X = problem.bounds.sample(np.random.default_rng(0), 2)
                problem.evaluate_instances(X, np.array([0, min(1, job.spec.runs - 1)]))
            optimizer = job.optimizer_cls(
                job.params, problem.bounds,
                np.random.default_rng(np.random.SeedSequence(job.spec.seed, spawn_key=(2**31,))))
            run(problem, optimizer, min(job.budget, 2 * job.problem_config.ps))
    except Exception:  # noqa: BLE001 - the timed runs will meet and record the same fault
        log.debug("warm-up failed", exc_info=True)
    return time.perf_counter() - t0


def _job_key(job: Job, registry: Registry | None, problem: Problem) -> dict[str, Any]:
    plugins = {}
    if registry is not None:
        for kind, name in (("problem", job.problem_name), ("optimizer", job.optimizer_name)):
            source = registry.provenance(kind, name)
            plugins[kind] = [source.get("distribution"), source.get("version")]
    return rec.job_key(
        {**job.problem_settings(), "name": job.problem_name},
        {**job.optimizer_settings(), "name": job.optimizer_name},
        job.spec.seed, job.budget, plugins=plugins, data=problem.content_digest(),
    )


def analyse_job(job: Job, problem: Problem, job_dir: Path, optima_dir: Path,
                records: list[dict[str, Any]]) -> dict[int, float]:
    """What the records allow, for a problem with residuals and a known truth: the Cramér–Rao
    bounds of its design (``job_dir/identifiability.json``) and each instance's optimum
    (``optima_dir/<key>.json``, shared by the jobs of a sweep; see :mod:`.analysis`).
    Returns each run's relative gap ``(f_best - f*) / f*`` to its instance's optimum."""
    from .analysis.identifiability import cramer_rao
    from .analysis.optimum import update_instance_optimum
    from .api import offers_residuals

    if problem.x_true is None or not offers_residuals(type(problem)):
        return {}
    target = job_dir / "identifiability.json"
    if not target.is_file():
        crb = cramer_rao(problem)
        if crb is not None:
            rec.write_json_atomic(target, crb)
    bests: dict[int, list[tuple[np.ndarray, float]]] = {}
    for record in records:
        res = record.get("result") or {}
        x, f = res.get("x_best"), res.get("f_best")
        if record["status"] == "ok" and x and None not in x and f is not None:
            bests.setdefault(record["run_index"], []).append((np.asarray(x, float), f))
    by_instance: dict[str | None, tuple[Problem, list, list[int]]] = {}
    for i in range(job.spec.runs):
        inst = problem.instance(i)
        entry = by_instance.setdefault(inst.instance_id(), (inst, [], []))
        entry[1].extend(bests.get(i, []))
        entry[2].append(i)
    gaps: dict[int, float] = {}
    for inst, runs, indices in by_instance.values():
        f_opt = update_instance_optimum(inst, job.problem_settings(), optima_dir, runs)["f_opt"]
        for i in indices:
            for _, f in bests.get(i, []):
                gaps[i] = (f - f_opt) / f_opt if f_opt > 0 else f - f_opt
    return gaps


def _score(gaps: Mapping[int, float], records: list[dict[str, Any]]) -> float | None:
    """The job's search score (see :class:`JobSummary`); ``inf`` when a run failed."""
    if gaps:
        values = list(gaps.values())
    else:
        values = []
        for record in records:
            f = (record.get("result") or {}).get("f_best")
            values.append(float("inf") if record["status"] != "ok" or f is None else float(f))
    return float(np.median(values)) if values else None


def _read_records(paths: list[Path]) -> list[dict[str, Any]]:
    """The job's readable records (an unreadable one is left out: resume runs it again)."""
    records = []
    for path in paths:
        try:
            records.append(rec.read_record(path))
        except rec.CorruptRecordError:
            continue
    return records


def run_job(job: Job, job_dir: str | Path, registry: Registry | None = None,
            problems: ProblemCache | None = None, optima_dir: Path | None = None
            ) -> JobSummary:
    """Run every run of ``job`` and write one record per run into ``job_dir/records``; then
    write what the records allow (:func:`analyse_job`) into ``optima_dir`` (default
    ``job_dir/optima``)."""
    problem = (problems or ProblemCache(size=1)).get(job)
    problem.set_threads(job.spec.threads or available_cores())
    # Build one optimizer up front: a fault in its constructor stops the job before any run.
    job.optimizer_cls(job.params, problem.bounds, run_rng(job.spec.seed, 0))
    provenance = {kind: (registry.provenance(kind, name) if registry is not None else {})
                  for kind, name in (("problem", job.problem_name),
                                     ("optimizer", job.optimizer_name))}
    job_dir = Path(job_dir)
    job_dir.mkdir(parents=True, exist_ok=True)
    problem.write_artifacts(job_dir)
    key = _job_key(job, registry, problem)
    spec = job.spec
    summary = JobSummary(job_dir, job.problem_name, job.optimizer_name, spec.runs, 0, 0, [],
                         [], 0.0)
    start = time.perf_counter()
    bar = _progress_bar(spec.runs, f"{job.optimizer_name} on {job.problem_name}",
                        enabled=spec.progress)
    with _one_blas_thread():
        try:
            todo: list[tuple[int, str, Path]] = []
            for i in range(spec.runs):
                rid = rec.run_id(key, i)
                path = rec.record_path(job_dir, i, rid)
                summary.record_paths.append(path)
                if spec.resume and _existing_ok(path, rid):
                    summary.skipped += 1
                    bar.update(1)
                    continue
                todo.append((i, rid, path))
            lockstep = len(todo) > 1 and joins_lockstep(job, problem)
            if todo:
                summary.warmup_s = _warm_up(job, problem, lockstep)
            if lockstep:
                done = _lockstep_runs(job, problem, todo, provenance, summary)
            else:
                done = ((path, _one_run(job, problem.instance(i), i, rid, provenance, summary))
                        for i, rid, path in todo)
            for path, record in done:
                rec.write_record(path, record)
                summary.ran += 1
                bar.update(1)
                if record["result"] is not None:
                    bar.set_postfix_str(_postfix(record), refresh=False)
        finally:
            bar.close()
        records = _read_records(summary.record_paths)  # once, for all that follows
        gaps: dict[int, float] = {}
        try:
            gaps = analyse_job(job, problem, job_dir, Path(optima_dir or job_dir / "optima"),
                               records)
        except Exception as exc:  # noqa: BLE001 - the runs are recorded; say what failed
            log.warning("the optimum / identifiability analysis failed: %s: %s",
                        type(exc).__name__, exc)
        summary.score = _score(gaps, records)
        summary.wall_time_s = time.perf_counter() - start
    best = best_of(records)
    if best is not None:  # the best run's own instance: its record is the one it fitted
        write_best_signals(job_dir, problem.instance(int(best[1]["run_index"])), *best)
    return summary


def _one_run(job: Job, problem: Problem, i: int, rid: str, provenance: Mapping[str, Any],
             summary: JobSummary) -> dict[str, Any]:
    started = _dt.datetime.now(_dt.timezone.utc).isoformat()
    t0 = time.perf_counter()
    result: RunResult | None = None
    error: BaseException | None = None
    try:
        with _time_limit(job.spec.run_timeout_s):
            optimizer = job.optimizer_cls(job.params, problem.bounds, run_rng(job.spec.seed, i))
            optimizer.name = job.optimizer_name
            result = run(problem, optimizer, job.budget)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # crash isolation: record it (SystemExit too), go on
        error = exc
        summary.failed.append(i)
        log.error("run %d of %s on %s failed: %s: %s", i, job.optimizer_name, job.problem_name,
                  type(exc).__name__, exc)
    return rec.make_record(
        rid=rid, run_index=i, problem=problem, problem_name=job.problem_name,
        problem_settings=job.problem_settings(), problem_plugin=provenance["problem"],
        optimizer_name=job.optimizer_name, optimizer_settings=job.optimizer_settings(),
        optimizer_plugin=provenance["optimizer"], seed=job.spec.seed, budget=job.budget,
        result=result, error=error, started_at=started, wall_time_s=time.perf_counter() - t0,
    )


def joins_lockstep(job: Job, problem: Problem) -> bool:
    """Whether the runs of ``job`` can run in lockstep (see module): the problem's values do
    not depend on the batch, and the optimizer asks and tells in the run loop's own thread and
    needs only objective values."""
    cls = job.optimizer_cls
    return (bool(getattr(problem, "rows_independent", False))
            and not getattr(cls, "wants_residuals", False)
            and not issubclass(cls, LoopOptimizer))


def _lockstep_runs(job: Job, problem: Problem, todo: list[tuple[int, str, Path]],
                   provenance: Mapping[str, Any], summary: JobSummary
                   ) -> Iterator[tuple[Path, dict[str, Any]]]:
    """The runs ``todo`` (index, run id, record path) in lockstep; (path, record) of each, in
    order. A run whose optimizer cannot be built fails alone, as in :func:`_one_run`."""
    started = _dt.datetime.now(_dt.timezone.utc).isoformat()
    timeout = job.spec.run_timeout_s
    lanes: list[Lane] = []
    outcomes: dict[int, RunResult | BaseException] = {}
    built_s: dict[int, float] = {}
    for i, _rid, _path in todo:
        inst = problem.instance(i)
        t0 = time.perf_counter()
        try:
            optimizer = job.optimizer_cls(job.params, inst.bounds, run_rng(job.spec.seed, i))
            optimizer.name = job.optimizer_name
            lanes.append(Lane(inst, optimizer, job.budget, instance=i))
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # crash isolation: this run only
            outcomes[i] = exc
        built_s[i] = time.perf_counter() - t0
        if timeout is not None and i not in outcomes and built_s[i] > timeout:
            lanes.pop()
            outcomes[i] = RunTimeoutError(f"the run took longer than run_timeout_s={timeout:g} s")
    results = run_many(problem, lanes, timeout_s=None if timeout is None else timeout)
    outcomes.update((lane.instance, out) for lane, out in zip(lanes, results))
    for i, rid, path in todo:
        out = outcomes[i]
        result = out if isinstance(out, RunResult) else None
        error = None if result is not None else out
        if error is not None:
            summary.failed.append(i)
            log.error("run %d of %s on %s failed: %s: %s", i, job.optimizer_name,
                      job.problem_name, type(error).__name__, error)
        seconds = built_s[i] + (result.wall_time_s if result is not None else 0.0)
        yield path, rec.make_record(
            rid=rid, run_index=i, problem=problem.instance(i), problem_name=job.problem_name,
            problem_settings=job.problem_settings(), problem_plugin=provenance["problem"],
            optimizer_name=job.optimizer_name, optimizer_settings=job.optimizer_settings(),
            optimizer_plugin=provenance["optimizer"], seed=job.spec.seed, budget=job.budget,
            result=result, error=error, started_at=started, wall_time_s=seconds,
        )


def run_from_config(cfg: Any, job_dir: str | Path, registry: Registry | None = None,
                    problems: ProblemCache | None = None, optima_dir: Path | None = None
                    ) -> JobSummary:
    """Parse and check the composed config ``cfg`` (:func:`vpid_bench.spec.parse_job`), then
    run the job into ``job_dir``. Raises :class:`~vpid_bench.api.ConfigError` (before any
    run) for a bad value."""
    registry = registry if registry is not None else Registry()
    return run_job(parse_job(cfg, registry), job_dir, registry, problems, optima_dir)


def _postfix(record: Mapping[str, Any]) -> str:
    res = record["result"]
    text = f"f={res['f_best']:.3g}" if res["f_best"] is not None else "f=inf"
    for name, value in list((res.get("metrics") or {}).items())[:1]:
        text += f" {name}={value:.4g}" if value is not None else f" {name}=inf"
    return text


class _NoBar:
    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, s: str, refresh: bool = True) -> None:
        pass

    def close(self) -> None:
        pass


def _progress_bar(total: int, desc: str, enabled: bool) -> Any:
    """A tqdm bar on stderr (runs done of total, elapsed, rate), or a silent stand-in."""
    if not enabled:
        return _NoBar()
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="run", file=sys.stderr, dynamic_ncols=True,
                mininterval=0.5)


__all__ = ["JobSummary", "ProblemCache", "RunTimeoutError", "joins_lockstep", "run_from_config",
           "run_job", "run_rng"]
