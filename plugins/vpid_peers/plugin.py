"""``optimizer=cmaes`` and ``optimizer=nevergrad``, registered with vpid-bench.

Each is registered only when its library (``cma``, ``nevergrad``: the ``peers`` extra) can
be found; finding it does not import it, so start-up stays fast (``import nevergrad`` alone
costs about 3 s).
"""

from __future__ import annotations

from collections.abc import Callable

from vpid_bench import hookimpl

from .unit_box import library_available


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """Register ``cmaes`` and ``nevergrad`` when their libraries are installed."""
    if library_available("cma"):
        from .cmaes import CMAES

        register("cmaes", CMAES)
    if library_available("nevergrad"):
        from .nevergrad_opt import NevergradOptimizer

        register("nevergrad", NevergradOptimizer)
