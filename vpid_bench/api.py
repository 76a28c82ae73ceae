"""The plugin API in one place: the two interfaces every plugin implements (:class:`Problem`
and :class:`Optimizer`) and everything a plugin uses with them.

A problem maps a population of candidate vectors (rows, in physical units) to objective
values; an optimizer proposes populations (``ask``) and learns their values (``tell``); the
run loop between them owns the budget (docs/plugins.md). This module only gathers names from
the small modules (which never import it back); ``from vpid_bench import ...`` offers the
same names.
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
from .problem_kit import ChannelFit, FrozenMap, freeze_fields
from .store.record_csv import ColumnMap, CsvRecord, CsvTable, RecordColumn

__all__ = [
    "FILLED_PARAMS", "PROTOCOL_KEYS", "Bounds", "ChannelFit", "ColumnMap", "ConfigError",
    "CsvRecord", "CsvTable", "FrozenMap", "GenerationalOptimizer", "LoopOptimizer", "Optimizer",
    "OptimizerContractError", "OptimizerParams", "PluginError", "Problem", "ProblemConfig",
    "RecordColumn", "VpidBenchError", "added_setting", "check_compatible", "default_budget",
    "freeze_fields", "offers_residuals", "registered_optimizer", "relative_errors_percent",
    "file_sha256", "write_text_atomic",
]
