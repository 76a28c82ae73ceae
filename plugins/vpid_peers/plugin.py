"""The peers registered with vpid-bench; ``cmaes`` and ``nevergrad`` only when their library
can be found, without importing it (``import nevergrad`` costs about 3 s)."""

from __future__ import annotations

import importlib.util
from collections.abc import Callable

from vpid_bench import hookimpl

from .hybrid import DELeastSquares
from .lsq import LeastSquares
from .scipy_de import ScipyDE


def library_available(module: str) -> bool:
    """True when ``module`` can be imported; finds it without importing it (milliseconds)."""
    return importlib.util.find_spec(module) is not None


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """One register call per optimizer; cmaes and nevergrad when their library is installed."""
    register("scipy_de", ScipyDE)
    register("lsq", LeastSquares)
    register("de_lsq", DELeastSquares)
    if library_available("cma"):
        from .cmaes import CMAES

        register("cmaes", CMAES)
    if library_available("nevergrad"):
        from .nevergrad_opt import NevergradOptimizer

        register("nevergrad", NevergradOptimizer)
