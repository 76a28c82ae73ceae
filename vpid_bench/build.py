"""Building problems and optimizers from configs, and the seed stream of each run.

The job builds through these functions, and so do scripts and tests that drive a problem or an
optimizer alone (``build_problem(registry, {"name": "sphere"})``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .optimizer import Optimizer
from .params import build_dataclass
from .plugins import Registry
from .problem import Problem
from .spec import Job, check_protocol


class ProblemCache:
    """Problems built in this process, by (class, name, config): jobs that share a problem
    config share one instance, so a costly set-up is done once per process (``evaluate`` is
    a pure function of the config: no result changes)."""

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
    cls = registry.problem(cfg.get("name"))
    config = build_dataclass(cls.Config, cfg, prefix="problem")
    check_protocol(config)
    problem = cls(config)
    problem.name = cfg.get("name")
    return problem


def optimizer_params(registry: Registry, cfg: Mapping) -> tuple[type[Optimizer], Any]:
    """The optimizer class named by ``cfg['name']`` and its validated ``Params`` (tests,
    scripts: the keys the job fills in may be given; ``budget`` defaults to the protocol's)."""
    cls = registry.optimizer(cfg.get("name"))
    return cls, build_dataclass(cls.Params, cfg, prefix="optimizer")


def run_rng(seed: int, run_index: int) -> np.random.Generator:
    """The optimizer's random stream of run ``run_index``: ``SeedSequence(seed,
    spawn_key=(run_index,))``, so runs are independent and any one can be repeated alone."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(run_index,)))
