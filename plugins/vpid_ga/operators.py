"""The operators of MATLAB R2014b's ``ga`` (default options, bounded problem), each a pure
function named after the MATLAB function it emulates and tested alone."""

from __future__ import annotations

import dataclasses

import numpy as np


def matlab_round(x: float) -> int:
    """MATLAB's ``round`` (half away from zero), not Python's banker's rounding."""
    return int(np.floor(abs(x) + 0.5) * np.sign(x))


def fitscalingrank(scores: np.ndarray, n_parents: int) -> np.ndarray:
    """Rank scaling: the member of rank ``k`` (1 = best score) gets ``1/sqrt(k)``, scaled so
    the expectations sum to ``n_parents``. Ties are ranked by position (a stable sort), as
    MATLAB's ``sort`` does; ``inf`` scores rank last."""
    order = np.argsort(scores, kind="stable")
    raw = np.empty(len(scores))
    raw[order] = 1.0 / np.sqrt(np.arange(1, len(scores) + 1))
    return n_parents * raw / raw.sum()


def selectionstochunif(
    expectation: np.ndarray, n_parents: int, rng: np.random.Generator
) -> np.ndarray:
    """Stochastic uniform selection: equally spaced pointers from one random offset."""
    wheel = np.cumsum(expectation) / np.sum(expectation)
    positions = (rng.random() + np.arange(n_parents)) / n_parents
    picks = np.searchsorted(wheel, positions, side="right")
    return np.minimum(picks, len(expectation) - 1)


def crossoverscattered(
    population: np.ndarray, parents: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Scattered crossover: each gene from ``p1`` when a uniform is > 0.5, else from ``p2``."""
    p1, p2 = population[parents[0::2]], population[parents[1::2]]
    return np.where(rng.random(p1.shape) > 0.5, p1, p2)


@dataclasses.dataclass
class AdaptiveStep:
    """``mutationadaptfeasible``'s step: 1 in generations 1 and 2; then ``min(1, 4 step)``
    when the best score improved between the last two completed generations (MATLAB's
    ``state.Best(end) < state.Best(end-1)``), else ``max(sqrt(eps), step / 4)``."""

    step: float = 1.0

    def update(self, generation: int, best_history: list[float]) -> float:
        """The step for ``generation`` (1-based) after the completed generations' best scores."""
        if generation <= 2 or len(best_history) < 2:
            self.step = 1.0
        elif best_history[-1] < best_history[-2]:
            self.step = min(1.0, self.step * 4.0)
        else:
            self.step = max(np.sqrt(np.finfo(float).eps), self.step / 4.0)
        return self.step
