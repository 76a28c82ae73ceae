"""``optimizer=scipy_de``: ``scipy.optimize.differential_evolution`` through the bridge, one
generation per batch (``vectorized=True``), drawing from the run's generator; the keys and the
four settings that differ from scipy's defaults, and why: docs/peers.md.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, Literal

import numpy as np

from vpid_bench import ConfigError, LoopOptimizer, OptimizerParams

Strategy = Literal[
    "best1bin", "best1exp", "rand1bin", "rand1exp", "rand2bin", "rand2exp",
    "randtobest1bin", "randtobest1exp", "currenttobest1bin", "currenttobest1exp",
    "best2bin", "best2exp",
]


@dataclasses.dataclass(frozen=True)
class ScipyDEParams(OptimizerParams):
    """scipy's keys and defaults (``strategy``, ``F`` or dithered in ``[F, F_max]``, ``CR``
    its ``recombination``) but ``tol`` (0: run every generation, as DE1-DE8)."""

    popsize: Literal["library", "ps"] = "library"
    strategy: Strategy = "best1bin"
    F: float = 0.5
    F_max: float | None = 1.0
    CR: float = 0.7
    tol: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 < self.F <= 2.0:
            raise ConfigError("optimizer.F", self.F, "a number in (0, 2]")
        if self.F_max is not None and not self.F <= self.F_max < 2.0:
            raise ConfigError("optimizer.F_max", self.F_max, f"null or a number in [F={self.F}, 2)")
        if not 0.0 <= self.CR <= 1.0:
            raise ConfigError("optimizer.CR", self.CR, "a number in [0, 1]")
        if not self.tol >= 0.0:
            raise ConfigError("optimizer.tol", self.tol, "a number >= 0")
        if self.popsize == "ps" and self.ps < 5:
            raise ConfigError("problem.ps", self.ps, "at least 5 (scipy's smallest population)")


class ScipyDE(LoopOptimizer):
    """scipy's differential evolution, one generation per batch."""

    Params = ScipyDEParams
    library = "scipy"

    def minimize(self, evaluate: Callable[[np.ndarray], Any]) -> Any:
        from scipy.optimize import differential_evolution

        p, b = self.params, self.bounds
        if p.popsize == "ps":
            init: Any = b.sample(self.rng, p.ps)
            maxiter, popsize = p.iterations, 15  # scipy sizes the population from init
        else:  # scipy's defaults; the budget (the bridge) ends the run
            init, popsize = "latinhypercube", 15
            maxiter = 10**9  # never the end: the run loop's budget is

        def batch(xt: np.ndarray) -> np.ndarray:
            # scipy passes (dim, S); its unit-cube scaling may round one ulp out of the box
            return evaluate(np.clip(np.atleast_2d(xt.T), b.lower, b.upper))

        return differential_evolution(
            batch,
            list(zip(b.lower, b.upper)),
            strategy=p.strategy,
            maxiter=maxiter,
            popsize=popsize,
            init=init,
            mutation=p.F if p.F_max is None else (p.F, p.F_max),
            recombination=p.CR,
            tol=p.tol,
            atol=0.0,
            polish=False,
            updating="deferred",
            vectorized=True,
            rng=self.rng,
        )
