"""The ``baselines`` entry point: registers random search as ``optimizer=random``."""

from __future__ import annotations

from collections.abc import Callable

from vpid_bench import hookimpl

from .random_search import RandomSearch


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """Register :class:`RandomSearch` as ``random``."""
    register("random", RandomSearch)
