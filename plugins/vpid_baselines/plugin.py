"""The ``baselines`` entry point: random search (``optimizer=random``) and the box centre
(``optimizer=centre``), what a method must beat."""

from __future__ import annotations

from collections.abc import Callable

from vpid_bench import hookimpl

from .centre import Centre
from .random_search import RandomSearch


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """Register :class:`RandomSearch` as ``random`` and :class:`Centre` as ``centre``."""
    register("random", RandomSearch)
    register("centre", Centre)
