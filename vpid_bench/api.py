"""The plugin API in one place: the two interfaces every plugin implements (:class:`Problem`
and :class:`Optimizer`) and everything a plugin uses with them.

The core knows no particular problem or optimization algorithm. A problem maps a population
of candidate vectors (rows) to objective values; an optimizer proposes populations (``ask``)
and learns their values (``tell``). The run loop in :mod:`vpid_bench.runner` sits between the
two and owns the evaluation budget, so an optimizer can neither overspend nor misreport.

Conventions
-----------
* Candidates are in physical units (kg, N/m, ...), rows of an ``(n, d)`` float array.
* Randomness is explicit: the optimizer receives a :class:`numpy.random.Generator`.
* Hyper-parameters are frozen dataclasses (``Optimizer.Params``, ``Problem.Config``), so an
  unknown or ill-typed key fails when the object is built (see :mod:`vpid_bench.params`).

This module only gathers names; each lives in a small module of its own (``errors``,
``bounds``, ``problem``, ``optimizer``, ``bridge``, ``fileio``, ``plugins``, and
``store.record_csv``, the reader of a user's record file), which import
each other and never this facade, so the package has no import circle.
``from vpid_bench import ...`` offers the same names (the one import line for plugins).
"""

from __future__ import annotations

from .bounds import Bounds, relative_errors_percent
from .bridge import LoopOptimizer
from .errors import ConfigError, OptimizerContractError, PluginError, VpidBenchError
from .fileio import file_sha256, write_text_atomic
from .optimizer import GenerationalOptimizer, Optimizer, OptimizerParams, check_compatible
from .params import added_setting
from .plugins import registered_optimizer
from .problem import (
    FILLED_PARAMS,
    PROTOCOL_KEYS,
    Problem,
    ProblemConfig,
    default_budget,
    offers_residuals,
)
from .store.record_csv import ColumnMap, CsvRecord, CsvTable, RecordColumn

__all__ = [
    "FILLED_PARAMS",
    "PROTOCOL_KEYS",
    "Bounds",
    "ColumnMap",
    "ConfigError",
    "CsvRecord",
    "CsvTable",
    "GenerationalOptimizer",
    "LoopOptimizer",
    "Optimizer",
    "OptimizerContractError",
    "OptimizerParams",
    "PluginError",
    "Problem",
    "ProblemConfig",
    "RecordColumn",
    "VpidBenchError",
    "added_setting",
    "check_compatible",
    "default_budget",
    "offers_residuals",
    "registered_optimizer",
    "relative_errors_percent",
    "file_sha256",
    "write_text_atomic",
]
