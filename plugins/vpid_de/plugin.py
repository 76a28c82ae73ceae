"""``optimizer=de1`` ... ``de8`` (Gökdağ 2014) and ``jade``, ``shade``, ``lshade`` (the
success-history adaptive DE family), registered with vpid-bench."""

from __future__ import annotations

from collections.abc import Callable

from vpid_bench import hookimpl

from .adaptive_de import ADAPTIVE
from .variants import STRATEGIES


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """Register DE1-DE8, JADE, SHADE and L-SHADE under their lower-case names."""
    for name, cls in {**STRATEGIES, **ADAPTIVE}.items():
        register(name, cls)
