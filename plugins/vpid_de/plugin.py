"""``optimizer=de1`` ... ``de8``: the DE family of Gökdağ (2014), registered with vpid-bench."""

from __future__ import annotations

from collections.abc import Callable

from vpid_bench import hookimpl

from .variants import STRATEGIES


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """Register DE1-DE8 under their lower-case names."""
    for name, cls in STRATEGIES.items():
        register(name, cls)
