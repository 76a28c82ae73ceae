"""vpid-bench: benchmark optimizers on parameter identification problems (see README.md).

Plugins implement :class:`vpid_bench.api.Problem` or :class:`vpid_bench.api.Optimizer` and
register them with the :data:`hookimpl` marker (see README.md, "Write an optimizer plugin").
"""

from .api import Bounds, Optimizer, OptimizerParams, Problem, ProblemConfig
from .hookspecs import hookimpl

__version__ = "0.1.0"

__all__ = [
    "Bounds",
    "Optimizer",
    "OptimizerParams",
    "Problem",
    "ProblemConfig",
    "hookimpl",
    "__version__",
]
