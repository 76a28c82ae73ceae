"""The ``baselines`` entry point: random search (``optimizer=random``) and the box centre
(``optimizer=centre``), what a method must beat (docs/baselines.md)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vpid_bench import Optimizer, OptimizerParams, hookimpl


@dataclass(frozen=True)
class RandomSearchParams(OptimizerParams):
    """No parameters beyond the batch size ``ps`` (candidates per ``ask``)."""


class RandomSearch(Optimizer):
    """Uniform sampling in the bounds, ``ps`` candidates per batch from the run's generator;
    no state and never done (the run loop keeps the best so far; the budget ends the run)."""

    Params = RandomSearchParams

    def ask(self) -> np.ndarray:
        """``ps`` uniform candidates (:meth:`Bounds.sample`: never an ulp outside the box)."""
        return self.bounds.sample(self.rng, self.params.ps)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        """Nothing to learn: the run loop records the best candidate."""


@dataclass(frozen=True)
class CentreParams(OptimizerParams):
    """No parameters: one candidate, the box centre."""


class Centre(Optimizer):
    """The do-nothing answer, ``(lower + upper) / 2``, asked once (one evaluation): what an
    answer that never looked at the data scores (NoRE 0 where the truth is the box's centre,
    as in the paper, which is why the suite's truths are random)."""

    Params = CentreParams

    def ask(self) -> np.ndarray:
        return ((self.bounds.lower + self.bounds.upper) / 2.0)[None, :]

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        self.done = True


@hookimpl
def vpid_bench_register_optimizers(register: Callable[[str, type], None]) -> None:
    """Register :class:`RandomSearch` as ``random`` and :class:`Centre` as ``centre``."""
    register("random", RandomSearch)
    register("centre", Centre)
