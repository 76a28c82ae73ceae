"""``optimizer=ga``: MATLAB R2014b's ``ga`` with default options on a bounded problem, one
generation as ``stepGA``: ``[elites; crossover children; mutation children]``, all of it
scored (elites too), ``ps * (iterations + 1)`` evaluations like the DE variants
(docs/optimizers.md, "The GA").
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar, Literal

import numpy as np

from vpid_bench import Bounds, ConfigError, GenerationalOptimizer, OptimizerParams

from .mutation import MUTATIONS
from .operators import (
    AdaptiveStep,
    crossoverscattered,
    fitscalingrank,
    matlab_round,
    selectionstochunif,
)


@dataclasses.dataclass(frozen=True)
class GAParams(OptimizerParams):
    """``elite_count``: members copied unchanged; ``-1``: R2014b's ``floor(0.05 ps)``.
    ``crossover_fraction``: MATLAB's CrossoverFraction (default 0.8). ``mutation``:
    ``adaptfeasible`` (MATLAB's) or ``scaled_halving`` (the project's earlier operator)."""

    elite_count: int = -1
    crossover_fraction: float = 0.8
    mutation: Literal["adaptfeasible", "scaled_halving"] = "adaptfeasible"

    def __post_init__(self) -> None:
        if self.ps < 2:
            raise ConfigError("problem.ps", self.ps, "at least 2 for ga")
        if self.iterations < 0:
            raise ConfigError("problem.iterations", self.iterations, "an integer >= 0")
        if not (self.elite_count == -1 or 0 <= self.elite_count < self.ps):
            raise ConfigError(
                "optimizer.elite_count", self.elite_count, f"-1 (default) or 0 ... {self.ps - 1}"
            )
        if not 0.0 <= self.crossover_fraction <= 1.0:
            raise ConfigError("optimizer.crossover_fraction", self.crossover_fraction,
                              "a number in [0, 1]")


def default_elite_count(ps: int) -> int:
    """R2014b's default EliteCount, ``floor(0.05 * PopulationSize)``."""
    return math.floor(0.05 * ps)


class GeneticAlgorithm(GenerationalOptimizer):
    """MATLAB-R2014b-like GA (the module docstring)."""

    Params: ClassVar[type[OptimizerParams]] = GAParams

    def __init__(self, params: GAParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        ps = params.ps
        self.n_elite = default_elite_count(ps) if params.elite_count == -1 else params.elite_count
        self.n_xover = matlab_round(params.crossover_fraction * (ps - self.n_elite))
        self.n_mutate = ps - self.n_elite - self.n_xover
        self.n_parents = 2 * self.n_xover + self.n_mutate
        self.population: np.ndarray | None = None
        self.scores: np.ndarray | None = None
        self.best_history: list[float] = []  # best score after each completed generation
        self._step = AdaptiveStep()
        self._mutate = MUTATIONS[params.mutation]

    # -- GenerationalOptimizer: the handshake lives in the core ---------------------------------
    def next_generation(self) -> np.ndarray:
        """``[elites; crossover children; mutation children]``, ``ps`` rows, all to be scored."""
        X, s = self.population, self.scores
        expectation = fitscalingrank(s, self.n_parents)
        parents = selectionstochunif(expectation, self.n_parents, self.rng)
        parents = parents[self.rng.permutation(self.n_parents)]
        elites = X[np.argsort(s, kind="stable")[: self.n_elite]]
        xover = crossoverscattered(X, parents[: 2 * self.n_xover], self.rng)
        step = self._step.update(self.generation + 1, self.best_history)
        mutants = self._mutate(
            X, parents[2 * self.n_xover :], step, self.bounds.lower, self.bounds.upper, self.rng
        )
        return np.vstack([elites, xover, mutants])

    def start(self, X: np.ndarray, f: np.ndarray) -> None:
        self.population, self.scores = X, f

    def advance(self, X: np.ndarray, f: np.ndarray) -> None:
        """The evaluated generation replaces the population (``stepGA`` scores the elites again)."""
        self.population, self.scores = X, f
        self.best_history.append(float(np.min(self.scores)))
