"""``optimizer=scipy_de``, ``lsq``, ``de_lsq``: the peers the paper's DE variants are compared
with, registered with vpid-bench. Imports are light: scipy.optimize is imported on first use."""

from __future__ import annotations

from collections.abc import Callable

from vpid_bench import hookimpl

from .hybrid import DELeastSquares
from .lsq import LeastSquares
from .scipy_de import ScipyDE


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """One register call per optimizer."""
    register("scipy_de", ScipyDE)
    register("lsq", LeastSquares)
    register("de_lsq", DELeastSquares)
