"""The operators of MATLAB R2014b's ``ga`` with default options on a bounded problem.

Pure functions of arrays and a ``numpy.random.Generator``, each named after the MATLAB
function it emulates, so each is tested alone:

* :func:`fitscalingrank`: expectation proportional to ``1/sqrt(rank)``, summing to the number
  of parents;
* :func:`selectionstochunif`: stochastic uniform (universal) sampling on a wheel laid out by
  the expectations, one random offset, equal steps;
* :func:`crossoverscattered`: each gene from parent 1 or parent 2 with probability 1/2;
* :class:`AdaptiveStep`: the step-size rule of ``mutationadaptfeasible``, a step that grows
  after an improving generation and shrinks after a stalled one.

The two mutation operators that use the step live in :mod:`vpid_ga.mutation`.
"""

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
    """Stochastic uniform selection: lay the expectations along a line of length 1 (a
    cumulative wheel), put ``n_parents`` equally spaced pointers on it starting at one
    uniform random offset in ``[0, 1/n_parents)``, and pick the section under each pointer.
    Returns parent indices in wheel order (the caller shuffles them, as ``stepGA`` does)."""
    wheel = np.cumsum(expectation) / np.sum(expectation)
    positions = (rng.random() + np.arange(n_parents)) / n_parents
    picks = np.searchsorted(wheel, positions, side="right")
    return np.minimum(picks, len(expectation) - 1)


def crossoverscattered(
    population: np.ndarray, parents: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Scattered crossover: ``parents`` is consumed in pairs ``(p1, p2)``; each child gene
    comes from ``p1`` when a fresh uniform number is > 0.5, else from ``p2``. Children of
    parents inside a box are inside the box, so no repair is needed for bounds."""
    p1, p2 = population[parents[0::2]], population[parents[1::2]]
    return np.where(rng.random(p1.shape) > 0.5, p1, p2)


@dataclasses.dataclass
class AdaptiveStep:
    """The step-size rule of ``mutationadaptfeasible``: ``step = 1`` in generations 1 and 2;
    from generation 3 on, ``step = min(1, 4 step)`` when the best score of the previous
    generation improved on the one before, else ``step = max(sqrt(eps), step / 4)``.

    MATLAB keeps the step in a persistent variable and compares ``state.Best(end)`` with
    ``state.Best(end-1)``, the best scores after the last two completed generations. The
    step is in the parameters' own units for ``mutation=adaptfeasible`` and a fraction of the
    box width for ``mutation=scaled_halving``."""

    step: float = 1.0

    def update(self, generation: int, best_history: list[float]) -> float:
        """The step for ``generation`` (1-based), given the best score after each completed
        generation (``best_history[-1]`` is the latest)."""
        if generation <= 2 or len(best_history) < 2:
            self.step = 1.0
        elif best_history[-1] < best_history[-2]:
            self.step = min(1.0, self.step * 4.0)
        else:
            self.step = max(np.sqrt(np.finfo(float).eps), self.step / 4.0)
        return self.step


