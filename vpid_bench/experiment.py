"""``run_from_config``: one job (one problem, one optimizer, ``runs`` independent runs).

This is a plain function of a composed config, so tests call it directly; the Hydra CLI
(:mod:`vpid_bench.cli`) is a thin shell around it.

Seeds: run ``i`` of a job draws its optimizer randomness from
``numpy.random.default_rng(SeedSequence(seed, spawn_key=(i,)))``, the same stream
``SeedSequence(seed).spawn(runs)[i]`` gives, so runs are independent and any single run can be
repeated alone. The measurement noise is seeded by the problem's own ``noise.seed`` (a problem
concern), so every optimizer of a comparison fits the same noisy record.

Resume: a run whose complete record (status ``ok``) already exists in the job directory is
skipped; missing, corrupt and failed runs are run again. Crash isolation: an exception inside
one run is written into that run's record (status ``failed``) and the job goes on.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import functools
import importlib.metadata
import logging
import platform
import socket
import sys
import time
import traceback
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from . import records as rec
from .api import ConfigError, Optimizer, Problem, VpidBenchError, relative_errors_percent
from .artifacts import best_vector, write_best_signals
from .params import build_dataclass, to_plain
from .plugins import Registry
from .runner import RunResult, run

log = logging.getLogger(__name__)

TOP_LEVEL_KEYS = ("problem", "optimizer", "seed", "runs", "budget", "resume", "progress", "report")


@dataclasses.dataclass
class JobSummary:
    """What a job did: where, how many runs were run, skipped and failed."""

    job_dir: Path
    problem: str
    optimizer: str
    runs: int
    ran: int
    skipped: int
    failed: list[int]
    record_paths: list[Path]
    wall_time_s: float


def _plain(cfg: Any) -> Any:
    """An OmegaConf node (or anything) as plain Python containers, interpolations resolved."""
    try:
        from omegaconf import DictConfig, ListConfig, OmegaConf

        if isinstance(cfg, (DictConfig, ListConfig)):
            return OmegaConf.to_container(cfg, resolve=True)
    except ImportError:  # pragma: no cover - hydra is a base dependency
        pass
    return to_plain(cfg)


def _int_key(cfg: Mapping, key: str, minimum: int, allow_none: bool = False) -> int | None:
    value = cfg.get(key)
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        allowed = f"an integer >= {minimum}" + (" or null" if allow_none else "")
        raise ConfigError(key, value, allowed)
    return value


@functools.lru_cache(maxsize=8)
def package_versions(extra: tuple[str, ...] = ()) -> dict[str, str]:
    """Versions of Python and of the packages that can change a result (looked up once per
    process: reading package metadata costs milliseconds, a record is written per run)."""
    out = {"python": platform.python_version()}
    for dist in ("vpid-bench", "numpy", "scipy", "numba", "hydra-core", "pluggy", *extra):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            continue
    return out


@functools.lru_cache(maxsize=64)
def _plugin_distribution(module_name: str) -> str | None:
    """The distribution that ships ``module_name``: found through the ``vpid_bench`` entry
    points first (milliseconds), through every installed package's file list otherwise
    (``packages_distributions`` reads them all: a tenth of a second or more)."""
    top = module_name.split(".")[0]
    for ep in importlib.metadata.entry_points(group="vpid_bench"):
        if ep.module.split(".")[0] == top and getattr(ep, "dist", None) is not None:
            return ep.dist.metadata["Name"]
    dists = importlib.metadata.packages_distributions().get(top, [])
    return dists[0] if dists else None


def _check_protocol(prefix: str, obj: Any) -> None:
    """``ps`` and ``iterations`` of a problem or optimizer must be integers >= 1."""
    for key in ("ps", "iterations"):
        value = getattr(obj, key, None)
        if value is not None and (not isinstance(value, int) or value < 1):
            raise ConfigError(f"{prefix}.{key}", value, "an integer >= 1")


#: Problems built in this process, by (class, name, config): the jobs of a sweep that share a
#: problem config (9 optimizers x the same ``ps``) share one instance, so a costly set-up
#: (the vehicle's reference simulation) is done once per process, not once per job. A
#: problem's ``evaluate`` is a pure function of its config (see Problem), so this changes no
#: result; the launcher tests compare records of the basic launcher (shared instances) and
#: of joblib workers (fresh ones).
_PROBLEMS: dict[Any, Problem] = {}
_PROBLEMS_MAX = 8


def build_problem(registry: Registry, cfg: Mapping) -> Problem:
    """The problem named by ``cfg['name']``, built from the rest of ``cfg`` (or re-used)."""
    name = cfg.get("name")
    cls = registry.problem(name)
    config = build_dataclass(cls.Config, cfg, prefix="problem")
    try:
        key: Any = (cls, name, config)
        hash(key)
    except TypeError:  # a config with unhashable values: build it every time
        key = None
    if key is not None and key in _PROBLEMS:
        return _PROBLEMS[key]
    problem = cls(config)
    problem.name = name
    if key is not None:
        if len(_PROBLEMS) >= _PROBLEMS_MAX:
            _PROBLEMS.pop(next(iter(_PROBLEMS)))
        _PROBLEMS[key] = problem
    return problem


def optimizer_params(registry: Registry, cfg: Mapping) -> tuple[type[Optimizer], Any]:
    """The optimizer class named by ``cfg['name']`` and its validated ``Params``."""
    cls = registry.optimizer(cfg.get("name"))
    return cls, build_dataclass(cls.Params, cfg, prefix="optimizer")


def default_budget(problem_cfg: Mapping) -> int:
    """The protocol: an initial population plus ``iterations`` generations of ``ps``."""
    return int(problem_cfg["ps"]) * (int(problem_cfg["iterations"]) + 1)


def run_rng(seed: int, run_index: int) -> np.random.Generator:
    """The optimizer's random stream of run ``run_index``: child ``run_index`` of ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(run_index,)))


def _result_section(result: RunResult, problem: Problem) -> dict[str, Any]:
    section: dict[str, Any] = {
        "x_best": result.x_best,
        "f_best": result.f_best,
        "evaluations": result.evaluations,
        "batches": result.batches,
        "stopped_by": result.stopped_by,
        "metrics": {},
        "rel_error_percent": None,
    }
    x_true = problem.x_true
    section["metrics"] = {str(k): float(v) for k, v in problem.metrics(result.x_best).items()}
    if x_true is not None and np.all(np.isfinite(result.x_best)):
        section["rel_error_percent"] = relative_errors_percent(result.x_best, x_true)
    return section


def make_record(
    *,
    rid: str,
    run_index: int,
    problem: Problem,
    optimizer_name: str,
    optimizer_plugin: str | None,
    params: Any,
    seed: int,
    budget: int,
    config: Mapping[str, Any],
    result: RunResult | None,
    error: BaseException | None,
    started_at: str,
    wall_time_s: float,
) -> dict[str, Any]:
    """Assemble the JSON record of one run (status ``ok`` with a result, or ``failed``)."""
    b = problem.bounds
    x_true = problem.x_true
    record: dict[str, Any] = {
        "schema": rec.SCHEMA,
        "run_id": rid,
        "run_index": run_index,
        "status": "ok" if error is None else "failed",
        "error": None,
        "problem": {
            "name": problem.name,
            "config": to_plain(problem.config),
            "info": problem.describe(),
        },
        "optimizer": {
            "name": optimizer_name, "plugin": optimizer_plugin, "params": to_plain(params)
        },
        "seeds": {"seed": seed, "run_index": run_index, "spawn_key": [run_index]},
        "budget": budget,
        "parameters": {
            "names": list(b.names),
            "units": list(b.units),
            "lower": b.lower,
            "upper": b.upper,
            "true": x_true,
        },
        "result": None,
        "trace": None,
        "config": config,
        "versions": dict(package_versions()),
        "timing": {
            "started_at": started_at,
            "wall_time_s": wall_time_s,
            "host": socket.gethostname(),
        },
    }
    if result is not None:
        record["result"] = _result_section(result, problem)
        record["trace"] = {"evaluations": result.trace_evaluations, "best": result.trace_best}
        record["timing"]["run_time_s"] = result.wall_time_s
    if error is not None:
        record["error"] = {
            "type": type(error).__name__,
            "message": str(error),
            "traceback": "".join(traceback.format_exception(error)),
        }
    return record


def _existing_ok(path: Path, rid: str) -> bool:
    if not path.exists():
        return False
    try:
        record = rec.read_record(path)
    except rec.CorruptRecordError as exc:
        log.warning("%s; running it again", exc)
        return False
    return record["run_id"] == rid and record["status"] == "ok"


def run_from_config(
    cfg: Mapping[str, Any],
    job_dir: str | Path,
    registry: Registry | None = None,
) -> JobSummary:
    """Run one job described by a composed config and write its records into ``job_dir``.

    Raises :class:`ConfigError` (before any run starts) for a bad config value.
    """
    plain = _plain(cfg)
    config = {k: v for k, v in plain.items() if k != "hydra"}
    unknown = sorted(set(config) - set(TOP_LEVEL_KEYS))
    if unknown:
        raise ConfigError(
            unknown[0], config[unknown[0]], "known top-level keys are " + ", ".join(TOP_LEVEL_KEYS)
        )
    seed = _int_key(config, "seed", 0)
    runs = _int_key(config, "runs", 1)
    if not (isinstance(config.get("problem"), Mapping)
            and isinstance(config.get("optimizer"), Mapping)):
        raise ConfigError("problem/optimizer", None, "both config groups must be selected")
    problem_cfg = dict(config["problem"])
    optimizer_cfg = dict(config["optimizer"])
    registry = registry if registry is not None else Registry()

    problem = build_problem(registry, problem_cfg)
    opt_cls, params = optimizer_params(registry, optimizer_cfg)
    opt_name = optimizer_cfg["name"]
    budget = _int_key(config, "budget", 1, allow_none=True) or default_budget(
        to_plain(problem.config)
    )
    _check_protocol("problem", problem.config)
    _check_protocol("optimizer", params)
    # Build one optimizer up front so a bad parameter stops the job before any run.
    opt_cls(params, problem.bounds, run_rng(seed, 0))
    plugin = _plugin_distribution(opt_cls.__module__)

    job_dir = Path(job_dir)
    job_dir.mkdir(parents=True, exist_ok=True)
    problem.write_artifacts(job_dir)
    key = rec.job_key(
        to_plain(problem.config) | {"name": problem.name},
        {"name": opt_name, **to_plain(params)},
        seed,
        budget,
    )

    resume = bool(config.get("resume", True))
    progress = bool(config.get("progress", True))
    summary = JobSummary(job_dir, problem.name, opt_name, runs, 0, 0, [], [], 0.0)
    start = time.perf_counter()
    bar = _progress_bar(runs, f"{opt_name} on {problem.name}", enabled=progress)
    try:
        for i in range(runs):
            rid = rec.run_id(key, i)
            path = rec.record_path(job_dir, i, rid)
            summary.record_paths.append(path)
            if resume and _existing_ok(path, rid):
                summary.skipped += 1
                bar.update(1)
                continue
            started = _dt.datetime.now(_dt.timezone.utc).isoformat()
            t0 = time.perf_counter()
            result: RunResult | None = None
            error: BaseException | None = None
            try:
                optimizer = opt_cls(params, problem.bounds, run_rng(seed, i))
                optimizer.name = opt_name
                result = run(problem, optimizer, budget)
            except (KeyboardInterrupt, SystemExit):
                raise
            except Exception as exc:  # crash isolation: record it, go on with the next run
                error = exc
                summary.failed.append(i)
                log.error("run %d of %s on %s failed: %s: %s", i, opt_name, problem.name,
                          type(exc).__name__, exc)
            record = make_record(
                rid=rid, run_index=i, problem=problem, optimizer_name=opt_name,
                optimizer_plugin=plugin, params=params, seed=seed, budget=budget, config=config,
                result=result, error=error, started_at=started,
                wall_time_s=time.perf_counter() - t0,
            )
            rec.write_record(path, record)
            summary.ran += 1
            bar.update(1)
            if result is not None:
                bar.set_postfix_str(_postfix(record), refresh=False)
    finally:
        bar.close()
        summary.wall_time_s = time.perf_counter() - start
    best = best_vector(summary.record_paths)
    if best is not None:
        write_best_signals(job_dir, problem, *best)
    return summary


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


__all__ = ["JobSummary", "run_from_config", "run_rng", "default_budget", "VpidBenchError"]
