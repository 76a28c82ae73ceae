"""vpid-bench: benchmark optimizers on parameter identification problems (see README.md).

The plugin API is one import line: everything a problem, optimizer or report-section plugin
uses is importable from here (``from vpid_bench import Problem, Optimizer, hookimpl, ...``).
Plugins implement :class:`Problem` or :class:`Optimizer` and register them with the
:data:`hookimpl` marker (docs/plugins.md); a few names are served on first use (``_LAZY``).
"""

from __future__ import annotations

import importlib
from typing import Any

from . import estimators
from .api import *  # noqa: F403  (the plugin API: its names and __all__ are api.py's)
from .api import __all__ as _api_names
from .hookspecs import hookimpl

__version__ = "0.1.0"

#: Names served on first use: ``name -> module`` (the report's section helpers and the
#: readers of a run's artifacts pull in the report's machinery).
_LAZY = {
    **dict.fromkeys(("Contribution", "HeadlineColumn", "ReportContext", "Section"),
                    ".report.sections"),
    **dict.fromkeys(("BestSignals", "read_best_signals"), ".store.artifacts"),
    **dict.fromkeys(("fit_structure", "structure_summary"), ".analysis.structures"),
}

#: api.py's names (written once, there), the estimators module, the hook marker, the version
#: and the names served on first use.
__all__ = [*_api_names, "estimators", "hookimpl", "__version__", *_LAZY]


def __getattr__(name: str) -> Any:
    """Import a lazily served name (PEP 562) on first use."""
    if name not in _LAZY:
        raise AttributeError(f"module 'vpid_bench' has no attribute {name!r}")
    return getattr(importlib.import_module(_LAZY[name], __name__), name)
