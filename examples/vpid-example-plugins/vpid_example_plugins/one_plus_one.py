"""optimizer=one_plus_one: a (1+1) evolution strategy with the 1/5th success rule.

One candidate per batch: the parent plus a Gaussian step of ``sigma`` times each parameter's
range. A better child replaces the parent and multiplies ``sigma`` by ``grow``; a worse one
multiplies it by ``grow ** -0.25``, so ``sigma`` holds still when one child in five wins.
Once ``sigma`` falls below ``sigma_min`` the search has converged as far as its steps can
see: it sets ``self.done = True`` and its run ends before the budget is spent.
"""

from dataclasses import dataclass

import numpy as np

from vpid_bench import ConfigError, Optimizer, OptimizerParams, hookimpl


@dataclass(frozen=True)
class OnePlusOneParams(OptimizerParams):  # ps, iterations: only the budget, ps (iterations + 1)
    sigma0: float = 0.2  # first step, as a fraction of each parameter's range
    sigma_min: float = 1e-4  # stop once the step is below this fraction
    grow: float = 1.5  # step factor after a success

    def __post_init__(self) -> None:
        if not 0 < self.sigma0 <= 1:
            raise ConfigError("optimizer.sigma0", self.sigma0, "a fraction in (0, 1]")
        if not 0 < self.sigma_min < self.sigma0:
            raise ConfigError("optimizer.sigma_min", self.sigma_min, "a fraction in (0, sigma0)")
        if not 1 < self.grow < np.inf:
            raise ConfigError("optimizer.grow", self.grow, "a factor > 1")


class OnePlusOne(Optimizer):
    """(1+1)-ES; the first batch is the starting point itself, drawn uniformly in the box."""

    Params = OnePlusOneParams

    def __init__(self, params, bounds, rng):
        super().__init__(params, bounds, rng)
        self.parent = np.clip(bounds.sample(rng, 1)[0], bounds.lower, bounds.upper)
        self.f_parent = None  # not evaluated yet
        self.sigma = params.sigma0

    def ask(self) -> np.ndarray:
        if self.f_parent is None:
            return self.parent[None].copy()
        step = self.sigma * self.bounds.width * self.rng.standard_normal(self.bounds.dim)
        return np.clip(self.parent + step, self.bounds.lower, self.bounds.upper)[None]

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        if self.f_parent is None:
            self.f_parent = f[0]
            return
        if f[0] < self.f_parent:
            self.parent, self.f_parent = X[0], f[0]
            self.sigma = min(1.0, self.sigma * self.params.grow)
        else:
            self.sigma *= self.params.grow**-0.25
        if self.sigma < self.params.sigma_min:
            self.done = True  # converged: the run loop ends the run here


@hookimpl
def vpid_bench_register_optimizers(register):
    register("one_plus_one", OnePlusOne)
