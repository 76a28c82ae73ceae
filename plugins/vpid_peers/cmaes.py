"""``optimizer=cmaes``: CMA-ES from the ``cma`` package (Hansen), as an ask/tell optimizer:
in the unit cube (one ``sigma0`` fits every parameter) from a uniform random start, inside
the box by cma's ``BoundTransform``, its normal deviates from the run's generator, done when
cma's criteria fire (``stop_reasons``) or the budget is spent (counted here: cma's
``maxfevals`` fires a generation late). The keys (``popsize``, ``restarts``: IPOP, BIPOP):
docs/optimizers.md, "optimizer=cmaes".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from vpid_bench import Bounds, ConfigError, Optimizer, OptimizerParams

from .coordinates import to_physical


@dataclass(frozen=True)
class CMAESParams(OptimizerParams):
    """``sigma0``: the start step (box fraction); 0.3 as cma advises (optimum in x0 ± 3 sigma0)."""

    sigma0: float = 0.3
    popsize: int | Literal["library", "ps"] = "library"
    restarts: Literal["none", "ipop", "bipop"] = "none"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.sigma0) and 0.0 < self.sigma0 <= 1.0):
            raise ConfigError("optimizer.sigma0", self.sigma0, "a fraction of the box in (0, 1]")
        if self.popsize == "ps" and self.ps < 2:
            raise ConfigError("problem.ps", self.ps, "at least 2 for cmaes (it recombines the "
                              "best half of each population)")
        if isinstance(self.popsize, int) and not 2 <= self.popsize <= 100_000:
            raise ConfigError("optimizer.popsize", self.popsize, "library, ps or an integer "
                              "from 2 to 100000")

    def population(self, dim: int) -> int:
        """The first population size for a search in ``dim`` parameters."""
        if self.popsize == "library":
            return 4 + int(3 * math.log(dim))
        return self.ps if self.popsize == "ps" else int(self.popsize)


class CMAES(Optimizer):
    """CMA-ES (``cma.CMAEvolutionStrategy``) driven by the run loop's ask/tell."""

    Params = CMAESParams
    library = "cma"

    def __init__(self, params: CMAESParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        import cma  # the extra; imported here so that registering the plugin stays cheap

        self._cma = cma
        self._popsize = params.population(bounds.dim)
        self._first_popsize = self._popsize
        self._large_popsize = self._popsize  # BIPOP: the large regime's current population
        self._sigma = params.sigma0
        self._spent = {"large": 0, "small": 0}  # BIPOP: evaluations used by each regime
        self._regime = "large"
        self._es = self._new_search()
        self.schedule = self.budget  # evaluations: the run's budget
        self._used = 0  # evaluations of the searches before the current one
        self._pending: list[np.ndarray] | None = None
        self.stop_reasons: dict[str, Any] = {}
        self.searches = 1

    def _new_search(self) -> Any:
        """A cma search from a random start in the box with the current population."""
        options = {
            "popsize": self._popsize,
            "bounds": [0.0, 1.0],
            "BoundaryHandler": "BoundTransform",
            "randn": lambda *shape: self.rng.standard_normal(shape),  # the run's generator
            "seed": float("nan"),  # nan: cma neither reads nor re-seeds numpy's global RNG
            "verbose": -9,
            "verb_log": 0,
            "verb_disp": 0,
        }
        x0 = self.rng.random(self.bounds.dim)
        return self._cma.CMAEvolutionStrategy(x0, self._sigma, options)

    def _next_search(self) -> None:
        """The next search's population and step (IPOP: doubled; BIPOP: the lesser-used regime)."""
        if self.params.restarts == "ipop":
            self._popsize *= 2
            return
        if self._spent["small"] < self._spent["large"]:
            self._regime = "small"
            u, v = self.rng.random(2)
            ratio = self._large_popsize / (2 * self._first_popsize)
            self._popsize = max(2, int(self._first_popsize * max(ratio, 1.0) ** (u * u)))
            self._sigma = self.params.sigma0 * 10.0 ** (-2.0 * v)
        else:
            self._regime = "large"
            self._large_popsize *= 2
            self._popsize, self._sigma = self._large_popsize, self.params.sigma0

    def ask(self) -> np.ndarray:
        if self._pending is None:
            self._pending = self._es.ask()
        return to_physical(np.array(self._pending), self.bounds)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        if self._pending is None or len(X) != len(self._pending):
            raise ValueError("tell() must follow ask() with the whole population it returned")
        f = np.asarray(f, dtype=float).reshape(-1)
        # cma ranks inf (a failed simulation) last; it refuses NaN, which the run loop never sends
        self._es.tell(self._pending, f.tolist())
        self._pending = None
        stop = dict(self._es.stop())
        used = self._used + self._es.countevals
        if used >= self.schedule:
            stop["schedule"] = self.schedule
        elif stop and self.params.restarts in ("ipop", "bipop"):  # a new search
            self._spent[self._regime] += self._es.countevals
            self._used = used
            self._next_search()
            self._es = self._new_search()
            self.searches += 1
            self.stop_reasons = {f"search {self.searches - 1}": stop}
            return
        if stop:
            self.stop_reasons = stop
            self.done = True
