"""The job spec: every top-level setting of a job, typed, and the one function that checks it.

A *job* is ``runs`` independent runs of one optimizer on one problem, all from one composed
config. :func:`parse_job` is the only place that turns that config into typed objects: the job
calls it, and the pre-flight calls it for every point of a sweep before the first job starts,
so a bad value anywhere stops the command before any work, in one line.

The protocol is the problem's (``problem.ps``, ``problem.iterations``, ``budget``): the job
fills it into each optimizer's ``Params``, never settable there (``optimizer.ps=7`` would
silently decouple the budget from the population).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from .contract import check_problem_class
from .errors import ConfigError
from .optimizer import Optimizer, OptimizerParams, check_compatible
from .params import build_dataclass, settings_of, to_plain
from .params_binding import check_params_bound
from .plugins import Registry
from .problem import FILLED_PARAMS, PROTOCOL_KEYS, Problem, ProblemConfig, default_budget

#: Caps that keep a typo from asking for hours or gigabytes (see docs/sweeps.md).
MAX_RUNS = 10_000
MAX_PS = 10_000
MAX_ITERATIONS = 1_000_000
MAX_BUDGET = 10**9
#: Longest run time limit (s), a week: larger ones overflow the OS timers (1e10 once failed
#: every run with "timestamp too large").
MAX_RUN_TIMEOUT_S = 7 * 24 * 3600.0
#: Longest ``grace_s`` (s): an hour.
MAX_GRACE_S = 3600.0
#: Values of the ``isolation`` key (see :class:`JobSpec`).
ISOLATION = ("auto", "process", "none")


@dataclasses.dataclass(frozen=True)
class JobSpec:
    """The top-level keys of a job (``vpid-bench seed=3 runs=10 ...``).

    ``seed``: run ``i`` draws from ``SeedSequence(seed, spawn_key=(i,))``. ``runs``: runs per
    job. ``budget``: evaluations per run (null: the protocol's). ``budget_per_dim``: the
    budget as a multiple of the problem's dimension (the budget ladder). ``resume``: skip runs
    already recorded. ``progress``: a progress bar. ``report``: a report at the end.
    ``archive``: rank a suite's archived built-in optimizers beside these runs. ``threads``:
    threads a problem may use (null: every core). ``run_timeout_s``: wall-time limit of a run
    (s; null: none). ``isolation``: ``process`` (supervised worker processes), ``none`` (this
    process) or ``auto`` (``process`` under the command). ``target``: stop a run within this
    relative gap of its instance's optimum certified in advance (null: use the budget).
    ``workers``: worker processes per job (null: every core). ``grace_s``: seconds past a
    limit (``run_timeout_s``, a set-up's or the analysis's) before a worker that has not
    answered (blocked in C, deaf to SIGALRM) is killed. :data:`OPERATIONAL_KEYS` never change
    a result.
    """

    seed: int = 0
    runs: int = 30
    budget: int | None = None
    budget_per_dim: int | None = None
    resume: bool = True
    progress: bool = True
    report: bool = True
    archive: bool = True
    threads: int | None = None
    run_timeout_s: float | None = None
    isolation: str = "auto"
    workers: int | None = None
    target: float | None = None
    grace_s: float = 10.0

    def __post_init__(self) -> None:
        _check_int("seed", self.seed, 0, 2**63 - 1)
        _check_int("runs", self.runs, 1, MAX_RUNS)
        _check_int("budget", self.budget, 1, MAX_BUDGET, nullable=True)
        _check_int("budget_per_dim", self.budget_per_dim, 1, MAX_BUDGET, nullable=True)
        if self.budget_per_dim is not None and self.budget is not None:
            raise ConfigError("budget_per_dim", self.budget_per_dim,
                              "either budget= or budget_per_dim=, not both")
        _check_int("threads", self.threads, 1, 1024, nullable=True)
        if self.run_timeout_s is not None and not 0 < self.run_timeout_s <= MAX_RUN_TIMEOUT_S:
            raise ConfigError("run_timeout_s", self.run_timeout_s,
                              f"a positive number of seconds up to {MAX_RUN_TIMEOUT_S:g} "
                              "(a week) or null")
        if self.isolation not in ISOLATION:
            raise ConfigError("isolation", self.isolation, " | ".join(ISOLATION))
        _check_int("workers", self.workers, 1, 1024, nullable=True)
        if not 0 < self.grace_s <= MAX_GRACE_S:
            raise ConfigError("grace_s", self.grace_s,
                              f"a positive number of seconds up to {MAX_GRACE_S:g}")
        if self.target is not None and not 0.0 <= self.target <= 1.0:
            raise ConfigError("target", self.target, "a relative gap from 0 to 1 (e.g. 1e-8) "
                              "or null")


#: The top-level keys, in the order they are documented.
TOP_LEVEL_KEYS = tuple(f.name for f in dataclasses.fields(JobSpec))
#: Keys that never change a result (they may differ between a sweep and its resume).
OPERATIONAL_KEYS = ("resume", "progress", "report", "archive", "threads", "isolation", "workers",
                    "grace_s")


def _check_int(key: str, value: int | None, low: int, high: int, nullable: bool = False) -> None:
    if value is None and nullable:
        return
    if not low <= value <= high:
        allowed = (f"an integer >= {low}" if high >= 2**62 else
                   f"an integer from {low} to {high}") + (" or null" if nullable else "")
        raise ConfigError(key, value, allowed)


def check_protocol(config: ProblemConfig) -> None:
    """``problem.ps`` and ``problem.iterations``: whole numbers within the caps."""
    _check_int("problem.ps", config.ps, 1, MAX_PS)
    _check_int("problem.iterations", config.iterations, 1, MAX_ITERATIONS)


@dataclasses.dataclass(frozen=True)
class Job:
    """A parsed, checked job: its spec, the problem and optimizer classes with their typed
    settings, and the budget of each run."""

    spec: JobSpec
    problem_name: str
    problem_cls: type[Problem]
    problem_config: ProblemConfig
    optimizer_name: str
    optimizer_cls: type[Optimizer]
    params: OptimizerParams
    budget: int
    #: per run index, the objective value at which the run stops (``target``; empty: none),
    #: filled in by :func:`vpid_bench.targets.with_stops` once the problem is built
    stop_at: Mapping[int, float] = dataclasses.field(default_factory=dict)

    def sized(self, dim: int) -> Job:
        """This job with ``budget_per_dim x dim`` evaluations per run when that is set (the
        dimension is known once the problem is built), else itself."""
        per = self.spec.budget_per_dim
        if per is None:
            return self
        budget = per * dim
        if budget > MAX_BUDGET:
            raise ConfigError("budget_per_dim", per, f"at most {MAX_BUDGET // max(dim, 1)} "
                              f"for a problem of {dim} parameters ({MAX_BUDGET} evaluations)")
        return dataclasses.replace(self, budget=budget,
                                   params=dataclasses.replace(self.params, budget=budget))

    def problem_settings(self) -> dict[str, Any]:
        """The problem's settings as plain data (the protocol included; a key added later
        left out at its default, :func:`~vpid_bench.params.added_setting`)."""
        return settings_of(self.problem_config)

    def optimizer_settings(self) -> dict[str, Any]:
        """The optimizer's own settings as plain data (what the job filled in left out: the
        protocol is the problem's and the budget the job's, each recorded there)."""
        return {k: v for k, v in to_plain(self.params).items() if k not in FILLED_PARAMS}


def plain_config(cfg: Any) -> dict[str, Any]:
    """A composed config (OmegaConf node or mapping) as plain data, interpolations resolved,
    the ``hydra`` node dropped. An interpolation that cannot be resolved is a ConfigError."""
    from omegaconf import DictConfig, OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    if isinstance(cfg, DictConfig):
        try:
            plain = OmegaConf.to_container(cfg, resolve=True)
        except OmegaConfBaseException as exc:
            key = getattr(exc, "full_key", None) or "config"
            raise ConfigError(str(key), "${...}", f"an interpolation that resolves "
                              f"({' '.join(str(exc).split()[:12])})") from None
    else:
        plain = to_plain(cfg)
    return {str(k): v for k, v in plain.items() if k != "hydra"}


def _group(config: Mapping[str, Any], group: str) -> tuple[str, dict[str, Any]]:
    node = config.get(group)
    if not isinstance(node, Mapping) or not isinstance(node.get("name"), str):
        raise ConfigError(group, node, f"a registered {group}, chosen with {group}=<name>")
    return node["name"], dict(node)


def parse_job(cfg: Any, registry: Registry) -> Job:
    """Check a composed config and build its job (no simulation, no file I/O beyond a
    plugin's config checks); :class:`ConfigError` names the first bad key."""
    config = plain_config(cfg)
    unknown = sorted(set(config) - {*TOP_LEVEL_KEYS, "problem", "optimizer"})
    if unknown:
        raise ConfigError(unknown[0], config[unknown[0]], "known top-level keys are problem, "
                          "optimizer, " + ", ".join(TOP_LEVEL_KEYS))
    spec = build_dataclass(JobSpec, {k: config[k] for k in TOP_LEVEL_KEYS if k in config})
    problem_name, problem_cfg = _group(config, "problem")
    optimizer_name, optimizer_cfg = _group(config, "optimizer")
    problem_cls = registry.problem(problem_name)
    optimizer_cls = registry.optimizer(optimizer_name)
    check_problem_class(problem_cls, problem_name)
    problem_config = build_dataclass(problem_cls.Config, problem_cfg, prefix="problem")
    check_protocol(problem_config)
    for key in FILLED_PARAMS:
        if key in optimizer_cfg:
            where = "budget" if key == "budget" else f"problem.{key}"
            raise ConfigError(f"optimizer.{key}", optimizer_cfg[key],
                              f"not settable on the optimizer: the job fills it in, set {where}")
    budget = spec.budget or default_budget(problem_config.ps, problem_config.iterations)
    if budget > MAX_BUDGET:
        raise ConfigError("problem.iterations", problem_config.iterations,
                          f"a protocol of at most {MAX_BUDGET} evaluations per run")
    filled = {**{k: getattr(problem_config, k) for k in PROTOCOL_KEYS}, "budget": budget}
    params = build_dataclass(optimizer_cls.Params, {**optimizer_cfg, **filled}, prefix="optimizer")
    check_params_bound(optimizer_cls, optimizer_name)
    optimizer_cls.check(params)
    check_compatible(problem_cls, optimizer_cls, optimizer_name, problem_name)
    return Job(spec, problem_name, problem_cls, problem_config, optimizer_name, optimizer_cls,
               params, budget)
