"""Run a job: a parsed job spec, the plugin registry and a folder in; run records out.

:func:`run_from_config` is a plain function of a composed config (tests call it directly; the
shell calls it once per job). Resume and crash isolation (docs/sweeps.md): a run whose
complete ``ok`` record (same run id) exists is skipped; an exception inside one run is written
into its record (status ``failed``) and the job goes on. With worker processes every call
into plugin code goes to them (:class:`_Here`: in this process).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import multiprocessing
import sys
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from tqdm import tqdm  # the progress bar: runs done of total, elapsed, rate

from .assemble import make_record
from .build import ProblemCache
from .errors import PluginError, VpidBenchError
from .facts import ProblemFacts, problem_facts
from .job_analysis import analyse_job, job_score, polish_share
from .job_runs import RunOutcome, joins_lockstep, now_utc, run_outcomes, warm_up
from .machine import available_cores, one_blas_thread
from .plugins import Registry
from .problem import kept_instance, offers_residuals
from .runner import RunTimeoutError, time_limit
from .spec import Job, parse_job
from .store import records as rec
from .store.artifacts import best_of, write_best_signals
from .store.job_status import read_job_status
from .store.record_check import check_record
from .targets import with_stops
from .worker_loop import probe
from .workers import Workers, can_send, is_timeout, outcomes_isolated

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
    #: The job's search score (:func:`vpid_bench.job_analysis.job_score`), lower is better.
    score: float | None = None


#: Where a record file that is not a valid record of its run (unreadable, or a field of the
#: wrong type: edited by hand) is moved, inside ``records/``, before its run is run again.
BAD_DIR = "bad"


def _valid(path: Path) -> tuple[dict[str, Any] | None, str]:
    """The valid record at ``path``, or ``(None, why)`` (unreadable, or a bad field)."""
    try:
        record = rec.read_record(path)
    except rec.CorruptRecordError as exc:
        return None, str(exc).removeprefix(f"{path}: ")
    bad = check_record(record, path.name)
    return (record, "") if bad is None else (None, f"field {bad}")


def _kept(path: Path, rid: str, set_aside: bool = False) -> bool:
    """Whether ``path`` holds this run's complete ``ok`` record, which a resume keeps. With
    ``set_aside``, an invalid file (it once failed its job on every resume) is moved aside."""
    if not path.is_file():
        return False
    record, why = _valid(path)
    if record is None and set_aside:
        _set_aside(path, why)
    return record is not None and record["run_id"] == rid and record["status"] == "ok"


def recorded_in_full(jobs: list[Job], job_dirs: list[Path], registry: Registry | None,
                     problems: ProblemCache | None = None) -> bool:
    """Whether every job of a sweep ended ``ok`` with the complete record of every run under
    the run ids it would have now: then the command writes nothing but the report. The
    problems' set-up runs as a job's does; any fault there: ``False`` (the jobs say why)."""
    if not jobs or len(jobs) != len(job_dirs) or any(
            (read_job_status(d) or {}).get("status") != "ok" for d in job_dirs):
        return False
    pool = Workers(1) if all(j.spec.isolation != "none" and can_send(j) is None
                             for j in jobs) else None
    try:
        return all(_recorded(job, Path(d), registry, pool or _Here(job, problems))
                   for job, d in zip(jobs, job_dirs, strict=True))
    except Exception:  # noqa: BLE001 - plugin code: its job runs it again and says why
        log.debug("the check for a sweep with nothing to run failed", exc_info=True)
        return False
    finally:
        if pool is not None:
            pool.close()


def _recorded(job: Job, job_dir: Path, registry: Registry | None, calls: Any) -> bool:
    """:func:`recorded_in_full` of one job: its run ids made as :func:`run_job` makes them."""
    if not job.spec.resume:
        return False
    job, facts = _set_up(job, calls)
    key = _job_key(job, registry, facts)
    return all(_kept(rec.record_path(job_dir, i, rec.run_id(key, i)), rec.run_id(key, i))
               for i in range(job.spec.runs))


def _set_up(job: Job, calls: Any) -> tuple[Job, ProblemFacts]:
    """The job sized by its problem's facts, with its stopping values (``target=``)."""
    limit = _limit(job, setup_limit_s(job))
    facts = calls.call(job, _facts, what="the problem's set-up (its instances, bounds, "
                       "x_true, instance_id(), describe(), content_digest())", limit=limit)
    job = job.sized(facts.dim)
    if job.spec.target is not None:
        job = dataclasses.replace(job, stop_at=calls.call(
            job, _stops, what="the certified optima's check", limit=limit))
    return job, facts


def _set_aside(path: Path, why: str) -> Path:
    """Move the record file ``path`` into ``records/bad/`` (numbered) and say so."""
    folder = path.parent / BAD_DIR
    _refuse_swapped(folder)
    folder.mkdir(exist_ok=True)
    target = folder / path.name
    n = 1
    while target.exists():
        target = folder / f"{path.stem}.{n}{path.suffix}"
        n += 1
    path.replace(target)
    print(f"warning: record {path} is not a valid record ({why}); set aside in {target} and "
          "its run is run again", file=sys.stderr, flush=True)
    return target


def _job_key(job: Job, registry: Registry | None, facts: ProblemFacts) -> dict[str, Any]:
    """What determines every run of the job but its index (hashed into each run id)."""
    plugins = {}
    if registry is not None:
        for kind, name in (("problem", job.problem_name), ("optimizer", job.optimizer_name)):
            source = registry.provenance(kind, name)
            plugins[kind] = [source.get("distribution"), source.get("version"),
                             source.get("code")]  # a plugin changed under the same version
    more: dict[str, Any] = {}
    if job.stop_at:  # only then: the run ids of every job without a target stay as they were
        more["target"] = [job.spec.target, sorted(job.stop_at.items())]
    return {"problem": {**job.problem_settings(), "name": job.problem_name},
            "optimizer": {**job.optimizer_settings(), "name": job.optimizer_name},
            "seed": job.spec.seed, "budget": job.budget, "plugins": plugins,
            "data": facts.content_digest, **more}


def _refuse_swapped(*folders: Path) -> None:
    """Refuse a job folder or its ``records/`` replaced by a symbolic link while the job runs
    (records were once written through it)."""
    for folder in folders:
        if Path(folder).is_symlink():
            raise VpidBenchError(f"{folder} became a symbolic link while the job ran; no record "
                              "is written through it (remove the link and --resume)")


def run_job(job: Job, job_dir: str | Path, registry: Registry | None = None,
            problems: ProblemCache | None = None, optima_dir: Path | None = None,
            pool: Workers | None = None) -> JobSummary:
    """Run every run of ``job``, one record each into ``job_dir/records``, then what the
    records allow into ``optima_dir`` (default ``job_dir/optima``). ``pool``: the sweep's
    worker processes (``isolation=auto`` uses them when given; ``process`` starts its own)."""
    pool, own_pool = _choose_workers(job, pool)
    try:
        calls = pool if pool is not None else _Here(job, problems)
        job_dir = Path(job_dir)
        job, facts = _set_up(job, calls)
        failure = _build_one_optimizer(job, calls)
        provenance = {kind: (registry.provenance(kind, name) if registry is not None else {})
                      for kind, name in (("problem", job.problem_name),
                                         ("optimizer", job.optimizer_name))}
        job_dir.mkdir(parents=True, exist_ok=True)
        written = calls.call(job, _write_artifacts, job_dir, what="the problem's write_artifacts()",
                             limit=_limit(job, setup_limit_s(job)))
        root = job_dir.resolve()  # a problem writing ../../x once went unnoticed
        for path in written:
            if (target := (job_dir / Path(path)).resolve()) != root and root not in target.parents:
                raise PluginError(f"problem {job.problem_name!r}: write_artifacts wrote {path} "
                                  f"outside its job folder {job_dir}; a problem writes only into "
                                  "the folder it is given")
        spec = job.spec
        summary = JobSummary(job_dir, job.problem_name, job.optimizer_name, spec.runs, 0, 0, [],
                             [], 0.0)
        start = time.perf_counter()
        with one_blas_thread():
            _run_missing(job, calls, facts, job_dir, _job_key(job, registry, facts), provenance,
                         summary, pool, failure)
        records = [r for r, _ in map(_valid, summary.record_paths) if r is not None]
        optima_dir = Path(optima_dir or job_dir / "optima")
        polished = _polish_at_once(job, pool, facts, job_dir, optima_dir, records)
        gaps = _after_runs(job, calls, "the optimum / identifiability analysis", _analysis,
                           analyse_job, job_dir, optima_dir, records, polished,
                           what="its gaps to the optimum are not",
                           limit=_limit(job, analysis_limit_s(job))) or {}
        summary.score = job_score(gaps, records)
        summary.wall_time_s = time.perf_counter() - start
        best = best_of(records)
        if best is not None:  # the best run's own instance: its record is the one it fitted
            _after_runs(job, calls, "the best run's signals", _signals, job_dir,
                        int(best[1]["run_index"]), *best,
                        what="best_signals.csv may be missing or out of date",
                        limit=_limit(job, analysis_limit_s(job)))
        return summary
    finally:
        if own_pool:
            pool.close()


class _Here:
    """Calls into plugin code in this process, as ``Workers.call`` makes them in a worker."""

    def __init__(self, job: Job, problems: ProblemCache | None) -> None:
        self.problem = (problems or ProblemCache(size=1)).get(job)
        self.problem.set_threads(job.spec.threads or available_cores())

    def call(self, job: Job, fn: Any, *args: Any, what: str, limit: float | None) -> Any:
        return fn(job, self.problem, *args)


def _choose_workers(job: Job, pool: Workers | None) -> tuple[Workers | None, bool]:
    """The job's worker processes (``None``: this process) and whether it started them."""
    mode = job.spec.isolation
    if mode == "none" or (mode == "auto" and pool is None):
        return None, False
    why = can_send(job)
    if why is not None:
        if mode == "process":
            raise VpidBenchError(f"isolation=process: the job cannot be sent to a worker "
                                 f"process ({why}); define plugin classes at module level, or "
                                 "set isolation=none")
        log.info("runs in this process: the job cannot be sent to a worker process (%s)", why)
        return None, False
    if pool is None:
        method = multiprocessing.get_start_method(allow_none=True)
        if method not in (None, "spawn", "fork", "forkserver"):
            raise VpidBenchError(f"isolation=process cannot start worker processes from this "
                                 f"process (start method {method!r}, e.g. a joblib launcher's "
                                 "worker); use isolation=none or the basic launcher")
        return Workers(job.spec.workers or available_cores()), True
    return pool, False


# --- what the job asks of its plugins: module-level functions, so a worker can run them
# (``calls.call(job, fn, *args)`` runs ``fn(job, problem, *args)``)


def setup_limit_s(job: Job) -> float | None:
    """Wall-time limit (s) of each set-up call into the problem: ``run_timeout_s x runs``,
    at least ``grace_s`` (so every run is still tried and recorded); ``None`` without
    ``run_timeout_s``."""
    limit = analysis_limit_s(job)
    return None if limit is None else max(job.spec.grace_s, limit)


@contextlib.contextmanager
def _limited(seconds: float | None, what: str) -> Iterator[None]:
    """:func:`~vpid_bench.runner.time_limit`, its error naming ``what`` and the limit."""
    try:
        with time_limit(seconds):
            yield
    except RunTimeoutError as exc:
        raise RunTimeoutError(f"{what} took longer than {seconds:g} s (its limit from "
                              "run_timeout_s)") from exc


def _facts(job: Job, problem: Any) -> ProblemFacts:
    with _limited(setup_limit_s(job), "the problem's set-up"):
        return problem_facts(problem, job.spec.runs)


def _stops(job: Job, problem: Any) -> dict[int, float]:
    with _limited(setup_limit_s(job), "the certified optima's check"):
        return with_stops(job, problem).stop_at


def _write_artifacts(job: Job, problem: Any, job_dir: Path) -> list[Any]:
    with _limited(setup_limit_s(job), "the problem's write_artifacts()"):
        return list(problem.write_artifacts(job_dir) or [])


def _analysis(job: Job, problem: Any, fn: Any, *args: Any) -> Any:
    """``fn(job, problem, *args)`` (the analysis or a share of its polish), time-limited."""
    with time_limit(analysis_limit_s(job)), one_blas_thread():
        return fn(job, problem, *args)


def _signals(job: Job, problem: Any, job_dir: Path, index: int, x: Any,
             source: dict[str, Any]) -> None:
    with _limited(analysis_limit_s(job), "the best run's signals"):
        write_best_signals(job_dir, kept_instance(problem, index), x, source)


def _limit(job: Job, limit: float | None) -> float | None:
    """A worker's allowance for a call limited to ``limit`` s in the worker itself."""
    return None if limit is None else limit + job.spec.grace_s


def _build_one_optimizer(job: Job, calls: Any) -> BaseException | None:
    """Build one optimizer up front: a fault in its constructor stops the job; one past the
    run's time limit is returned, and every run recorded as failed with it."""
    try:
        calls.call(job, probe, what="the optimizer's constructor",
                   limit=_limit(job, job.spec.run_timeout_s))
    except Exception as exc:
        if not is_timeout(exc):
            raise
        text = (f"{job.optimizer_name} on {job.problem_name}: {' '.join(str(exc).split())}; "
                "every run is recorded as failed with this reason")
        log.error("%s", text)
        print(f"error: {text}", file=sys.stderr, flush=True)
        return exc
    return None


def _after_runs(job: Job, calls: Any, name: str, fn: Any, *args: Any, what: str,
                limit: float | None) -> Any:
    """A call after the runs: its value, or ``None`` and one warning line."""
    try:
        return calls.call(job, fn, *args, what=name, limit=limit)
    except Exception as exc:  # noqa: BLE001 - the runs are recorded; say what failed
        _warn_failed(job, name, exc, what)
        return None


def _warn_failed(job: Job, name: str, exc: BaseException, what: str) -> None:
    """One warning line and log record: ``name`` failed; ``what`` is missing."""
    kind = getattr(exc, "remote_type", type(exc).__name__)
    text = " ".join(str(exc).split())[:300]
    log.warning("%s failed: %s: %s", name, kind, text)
    print(f"warning: {job.optimizer_name} on {job.problem_name}: {name} failed ({kind}: "
          f"{text}); the runs are recorded, {what}", file=sys.stderr, flush=True)


def _polish_at_once(job: Job, pool: Workers | None, facts: ProblemFacts, job_dir: Path,
                    optima_dir: Path, records: list[dict[str, Any]]
                    ) -> dict[str | None, dict[str, Any]] | None:
    """The job's optimum polishes shared out to its workers at once (one task per instance,
    :func:`~vpid_bench.job_analysis.polish_share`): the instance optima by instance id.
    ``None`` where the analysis polishes alone (in this process, one worker, no residuals)."""
    if pool is None or not offers_residuals(job.problem_cls):
        return None
    groups: dict[str | None, list[int]] = {}
    for i in range(job.spec.runs):
        groups.setdefault(facts.instance(i).id, []).append(i)
    workers = pool.how_many(job.spec.workers or pool.size, len(groups) + 1)
    if workers < 2:
        return None
    tasks = [(_analysis, (polish_share, job_dir, optima_dir, [], None))]
    tasks += [(_analysis, (polish_share, job_dir, optima_dir,
                           [r for r in records if r.get("run_index") in indices], indices))
              for indices in groups.values()]
    polished: dict[str | None, dict[str, Any]] = {}
    name = "the optimum / identifiability analysis"
    results = pool.calls(job, tasks, what=name, workers=workers,
                         limit=_limit(job, analysis_limit_s(job)))
    for value, error in results:
        if error is None and isinstance(value, dict):
            polished.update(value)
    errors = [error for _, error in results if error is not None]
    if errors:  # one line for all: a fault in the problem's residuals fails every task
        _warn_failed(job, name, errors[0], f"its gaps to the optimum are not where it failed "
                     f"({len(errors)} of its {len(tasks)} tasks)")
    return polished


#: Where records made under another run id (another plugin version, data file or setting)
#: are moved, inside ``records/``: kept for the curious, never read as records.
SUPERSEDED_DIR = "superseded"


def set_aside_superseded(job_dir: Path, key: Mapping[str, Any],
                         provenance: Mapping[str, Mapping[str, Any]] | None = None) -> int:
    """Move every record of ``job_dir`` whose run id is not the one this job gives its index
    (another data file, plugin release or code: the report once counted both) into
    ``records/superseded/``; say so in one line naming what changed. Returns how many."""
    folder = job_dir / rec.RECORDS_DIR
    moved = []
    for path in sorted(folder.glob("run-*.json")) if folder.is_dir() else []:
        named = rec.parse_record_name(path.name)
        if named is not None and named[1] != rec.run_id(key, named[0]):
            moved.append(path)
    if moved:
        why = _what_changed(moved, provenance or {})
        target = folder / SUPERSEDED_DIR
        _refuse_swapped(target)
        target.mkdir(exist_ok=True)
        for path in moved:
            path.replace(target / path.name)
        print(f"warning: {len(moved)} record(s) in {folder} were made {why}; set aside in "
              f"{target} (never counted) and their runs are run again", file=sys.stderr,
              flush=True)
    return len(moved)


def _what_changed(paths: list[Path], provenance: Mapping[str, Mapping[str, Any]]) -> str:
    """What made the records at ``paths`` another job's, as far as they tell: another
    release of a plugin, or its code changed under the same version; else general words."""
    found: set[str] = set()
    for path in paths[:20]:  # a few tell; a job folder may hold thousands
        try:
            old = rec.read_record(path)
        except rec.CorruptRecordError:
            continue
        for kind, now in provenance.items():
            was = (old.get(kind) or {}).get("plugin") if isinstance(old.get(kind), dict) else None
            if not isinstance(was, dict) or not now:
                continue
            name = f"{kind} plugin {now.get('plugin')!s}"
            if was.get("version") != now.get("version"):
                found.add(f"by another release of the {name} ({was.get('version')!s}, now "
                          f"{now.get('version')!s})")
            elif was.get("code") != now.get("code"):
                found.add(f"by other code of the {name} (its installed source changed under "
                          f"the same version {now.get('version')!s})" if was.get("code") else
                          f"before vpid-bench recorded the code of the {name}")
    return "; ".join(sorted(found)) or "from other data, plugins or settings"


def analysis_limit_s(job: Job) -> float | None:
    """Wall-time limit (s) of the job's analysis after its runs: ``run_timeout_s x runs``
    (``None`` without; a slow problem once made the analysis run for ever)."""
    limit = job.spec.run_timeout_s
    return None if limit is None else limit * max(1, job.spec.runs)


def _run_missing(job: Job, calls: Any, facts: ProblemFacts, job_dir: Path,
                 key: Mapping[str, Any], provenance: Mapping[str, Any], summary: JobSummary,
                 pool: Workers | None, failure: BaseException | None) -> None:
    """Run the runs without a complete record, here or in ``pool``'s workers, writing each
    record as soon as it is over. ``failure``: every run is recorded as failed with it."""
    spec = job.spec
    bar = tqdm(total=spec.runs, desc=f"{job.optimizer_name} on {job.problem_name}", unit="run",
               file=sys.stderr, dynamic_ncols=True, mininterval=0.5, disable=not spec.progress)
    try:
        todo: dict[int, tuple[str, Path]] = {}
        for i in range(spec.runs):
            rid = rec.run_id(key, i)
            path = rec.record_path(job_dir, i, rid)
            summary.record_paths.append(path)
            if spec.resume and _kept(path, rid, set_aside=True):
                summary.skipped += 1
                bar.update(1)
            else:
                todo[i] = (rid, path)
        set_aside_superseded(job_dir, key, provenance)
        for run in _outcomes(job, calls, facts, list(todo), summary, pool, failure):
            rid, path = todo[run.index]
            record = make_record(job, run, rid, facts.instance(run.index), provenance)
            _refuse_swapped(job_dir, path.parent)
            if not job_dir.is_dir():  # moved away: writing would re-create it, half empty
                raise VpidBenchError(f"{job_dir} was moved, renamed or removed while the job "
                                     "ran; no record is written there")
            rec.write_record(path, record)
            summary.ran += 1
            if run.error is not None:
                summary.failed.append(run.index)
            bar.update(1)
            if record["result"] is not None:
                bar.set_postfix_str(_postfix(record), refresh=False)
    finally:
        bar.close()


def _outcomes(job: Job, calls: Any, facts: ProblemFacts, todo: list[int], summary: JobSummary,
              pool: Workers | None, failure: BaseException | None) -> Any:
    """The outcomes of the runs in ``todo``: from ``pool``, here, or failed with ``failure``."""
    if failure is not None:
        started = now_utc()
        return iter([RunOutcome(i, failure, started, 0.0) for i in todo])
    lockstep = len(todo) > 1 and joins_lockstep(job, facts)
    if pool is not None:  # each worker warms up once per job
        return outcomes_isolated(pool, job, todo, lockstep)
    summary.warmup_s = warm_up(job, calls.problem, lockstep) if todo else 0.0
    return run_outcomes(job, calls.problem, todo, lockstep)


def run_from_config(cfg: Any, job_dir: str | Path, registry: Registry | None = None,
                    problems: ProblemCache | None = None, optima_dir: Path | None = None,
                    pool: Workers | None = None) -> JobSummary:
    """Parse and check the composed config ``cfg`` (:func:`vpid_bench.spec.parse_job`; a bad
    value raises :class:`~vpid_bench.api.ConfigError` before any run), then run the job."""
    registry = registry if registry is not None else Registry()
    return run_job(parse_job(cfg, registry), job_dir, registry, problems, optima_dir, pool)


def _postfix(record: Mapping[str, Any]) -> str:
    res = record["result"]
    text = f"f={res['f_best']:.3g}" if res["f_best"] is not None else "f=inf"
    for name, value in list((res.get("metrics") or {}).items())[:1]:
        text += f" {name}={value:.4g}" if value is not None else f" {name}=inf"
    return text
