"""Uniform random search: ``ps`` candidates per batch from the run's generator, until the
budget is spent; no state (the run loop keeps the best so far)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vpid_bench import Optimizer, OptimizerParams


@dataclass(frozen=True)
class RandomSearchParams(OptimizerParams):
    """No parameters beyond the batch size ``ps`` (candidates per ``ask``)."""


class RandomSearch(Optimizer):
    """Uniform sampling in the bounds; never done (the budget ends the run)."""

    Params = RandomSearchParams

    def ask(self) -> np.ndarray:
        """``ps`` uniform candidates, clipped (rounding may leave the box by an ulp)."""
        U = self.bounds.sample(self.rng, self.params.ps)
        return np.minimum(np.maximum(U, self.bounds.lower), self.bounds.upper)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        """Nothing to learn: the run loop records the best candidate."""
