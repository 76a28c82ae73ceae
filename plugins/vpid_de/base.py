"""The generational DE loop shared by DE1-DE8 (a variant names its mutation kernel and its
factors ``F``, ``K``: :mod:`vpid_de.variants`): ``ps`` uniform vectors, then generations of
``ps`` trials built from the current population only, ``ps * (iterations + 1)`` evaluations
(docs/optimizers.md, "The DE family").
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar, Literal

import numpy as np

from vpid_bench import Bounds, ConfigError, GenerationalOptimizer, OptimizerParams

from .kernels import (
    BOUNDS_RULES,
    MUTATIONS,
    BoundsRule,
    crossover_from_uniforms,
    greedy_selection,
    indices_from_keys,
)

#: Largest block of uniforms one generation draws, ``ps x (ps + 2 dim)`` floats (bytes): a
#: population of about 8,000 at most (docs/sweeps.md lists the caps).
MAX_RANDOM_BLOCK_BYTES = 512 * 1024**2


def check_finite(params: OptimizerParams) -> None:
    """Refuse a real-valued parameter that is not finite (``K=inf`` only degenerates runs)."""
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        if isinstance(value, float) and not np.isfinite(value):
            raise ConfigError(f"optimizer.{f.name}", value, "a finite number")


#: the choices of the ``draw`` key of DE6 and DE7
Draw = Literal["generation", "vector"]


@dataclasses.dataclass(frozen=True)
class DEParams(OptimizerParams):
    """``CR``: Eq. 8's crossover constant in [0, 1]. ``bounds``: the rule for a trial
    coordinate outside the box (the paper is silent; ``reinit`` as scipy's DE)."""

    CR: float = 0.9
    bounds: BoundsRule = "reinit"

    def __post_init__(self) -> None:
        check_finite(self)
        if not 0.0 <= self.CR <= 1.0:
            raise ConfigError("optimizer.CR", self.CR, "a number in [0, 1]")
        if self.iterations < 0:
            raise ConfigError("problem.iterations", self.iterations, "an integer >= 0")


class DifferentialEvolution(GenerationalOptimizer):
    """Generational DE, binomial crossover, greedy selection (the variants set the rest)."""

    Params: ClassVar[type[OptimizerParams]] = DEParams
    mutation: ClassVar[str] = "rand1"
    label: ClassVar[str] = "de"
    #: "numba" (fused compiled generation) or "numpy" (reference kernels); same results
    engine: ClassVar[str] = "numba"

    @classmethod
    def check(cls, params: OptimizerParams) -> None:
        """The mutation draws distinct vectors besides the target: ``ps`` must allow it."""
        n_random = MUTATIONS[cls.mutation][1]
        block = 8.0 * params.ps * params.ps  # the dimension adds 2 dim columns: left out
        if block > MAX_RANDOM_BLOCK_BYTES:
            largest = int((MAX_RANDOM_BLOCK_BYTES / 8) ** 0.5)
            raise ConfigError(
                "problem.ps", params.ps,
                f"at most {largest} for {cls.label} (each generation draws ps x (ps + 2 dim) "
                f"uniforms: about {block / 1024**3:.3g} GiB at ps = {params.ps})",
            )
        if params.ps < n_random + 1:
            raise ConfigError(
                "problem.ps",
                params.ps,
                f"at least {n_random + 1} for {cls.label} ({cls.mutation} draws "
                f"{n_random} distinct vectors besides the target)",
            )

    def __init__(self, params: DEParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        self.check(params)
        self._kernel, self._n_random = MUTATIONS[self.mutation]
        self._repair = BOUNDS_RULES[params.bounds]
        self._lower = bounds.lower
        self._upper = bounds.upper
        self._dim = bounds.dim
        self._fused = None  # the compiled generation, loaded on first use (engine "numba")
        self._F = np.empty(params.ps)  # buffer for a scalar F broadcast to every target
        self.population: np.ndarray | None = None
        self.fitness: np.ndarray | None = None

    # -- what a variant customises ------------------------------------------------------------
    def factors(self) -> dict[str, Any]:
        """The kernel's ``F`` (and ``K``) for the generation being built."""
        return {"F": self.params.F}

    def draw_factor(self, low: float, high: float, draw: str) -> float | np.ndarray:
        """A factor ~ U(low, high): a scalar, or a ``(ps, 1)`` column with ``draw='vector'``."""
        if draw == "vector":
            return self.rng.uniform(low, high, size=(self.params.ps, 1))
        return float(self.rng.uniform(low, high))

    # -- GenerationalOptimizer: the handshake lives in the core, generation and selection here
    def next_generation(self) -> np.ndarray:
        """One generation of trials (mutation, Eq. 8 crossover, bounds rule) from the factors
        (DE6, DE7), then ONE block of ``ps x (ps + 2 dim)`` uniforms, per row the index keys
        (ps - 1), ``rand_j`` (dim), ``rnbr`` (1), the reinit values (dim)."""
        X, f, ps, dim = self.population, self.fitness, self.params.ps, self._dim
        factors = self.factors()
        u = self.rng.random((ps, ps + 2 * dim))
        if self.engine == "numba":
            if self._fused is None:
                from .fused import BOUNDS_IDS, MUTATION_IDS, generation

                self._fused = generation
                self._ids = (MUTATION_IDS[self.mutation], BOUNDS_IDS[self.params.bounds])
            F = factors["F"]
            if isinstance(F, np.ndarray):
                F = np.ascontiguousarray(F.reshape(-1), dtype=float)
            else:
                self._F.fill(F)
                F = self._F
            return self._fused(
                X, f, u, self._n_random, self._ids[0], F, float(factors.get("K", 0.0)),
                float(self.params.CR), self._ids[1], self._lower, self._upper,
            )
        best = int(np.argmin(f))
        r = indices_from_keys(u[:, : ps - 1], self._n_random)
        V = self._kernel(X, best, r, **factors)
        c = ps - 1
        U = crossover_from_uniforms(X, V, self.params.CR, u[:, c : c + dim], u[:, c + dim])
        return self._repair(U, X, self._lower, self._upper, u[:, c + dim + 1 :])

    def start(self, X: np.ndarray, f: np.ndarray) -> None:
        self.population, self.fitness = X, f

    def advance(self, X: np.ndarray, f: np.ndarray) -> None:
        self.population, self.fitness = greedy_selection(self.population, self.fitness, X, f)
