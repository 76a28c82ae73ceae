"""Uniform random search: ``ps`` candidates per batch, drawn uniformly in the box.

Run ``i`` of a job draws from its own generator, so the candidates of a run are the rows of
``lower + U * (upper - lower)`` with ``U`` the generator's next ``(ps, dim)`` uniforms,
batch after batch, until the run loop's budget is spent. Nothing is learned from ``tell``:
the run loop keeps the best-so-far, so this optimizer keeps no state at all.
"""

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
        """``ps`` uniform candidates, clipped so that rounding cannot leave the box by an ulp
        (clipping changes no candidate that was already inside)."""
        U = self.bounds.sample(self.rng, self.params.ps)
        return np.minimum(np.maximum(U, self.bounds.lower), self.bounds.upper)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        """Nothing to learn: the run loop records the best candidate."""
