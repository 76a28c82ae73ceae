"""``optimizer=de_lsq``: DE4 (current-to-best/1, Gökdağ 2014; the installed ``de4``, looked up
by name) for ``fraction`` of the run's budget (``round(fraction budget / ps) - 1`` generations
after its initial population), then :mod:`vpid_peers.lsq` from its best vector until the
budget ends.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from vpid_bench import Bounds, ConfigError, LoopOptimizer, Optimizer, registered_optimizer

from .lsq import LSQParams, check_scaling, multistart

#: The first stage's class, looked up once per process (a registry load costs about 50 ms).
_first_stage = functools.cache(registered_optimizer)


@dataclasses.dataclass(frozen=True)
class DELSQParams(LSQParams):
    """``fraction``: DE4's share of the budget in [0, 1] (0: its initial population only).
    ``F``, ``CR``: DE4's (Table I). The other keys: :class:`~vpid_peers.lsq.LSQParams`."""

    fraction: float = 0.5
    F: float = 0.6
    CR: float = 0.9

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0.0 <= self.fraction <= 1.0:
            raise ConfigError("optimizer.fraction", self.fraction, "a number in [0, 1]")


class DELeastSquares(LoopOptimizer):
    """DE4 first, least squares from its best vector next."""

    Params = DELSQParams
    library = "scipy"  # least_squares (the DE stage is vpid-bench's de4)
    wants_residuals = True

    def __init__(self, params: DELSQParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        check_scaling(params, bounds)
        self._de_class: type[Optimizer] = _first_stage("de4")
        self._de_params = self._de_class.Params(
            ps=params.ps, iterations=max(0, round(params.fraction * self.budget / params.ps) - 1),
            F=params.F, CR=params.CR)

    def minimize(self, evaluate: Callable[[np.ndarray], Any]) -> None:
        de = self._de_class(self._de_params, self.bounds, self.rng)
        best_x, best_f = None, np.inf
        while not de.done:
            X = de.ask()
            f, _ = evaluate(X)
            de.tell(X, f)
            i = int(np.argmin(f))
            if f[i] < best_f:
                best_x, best_f = X[i].copy(), float(f[i])
        multistart(evaluate, self.params, self.bounds, self.residual_groups, self.rng,
                   first=best_x)
