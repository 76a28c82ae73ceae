"""``optimizer=ga``: a MATLAB-R2014b-like genetic algorithm, registered with vpid-bench."""

from __future__ import annotations

from collections.abc import Callable

from vpid_bench import hookimpl

from .ga import GeneticAlgorithm


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """Register the GA as ``ga``."""
    register("ga", GeneticAlgorithm)
