"""``optimizer=lsq``: multistart trust-region least squares on the residuals, reweighted to
minimise a sum of group norms (the vehicle's Eq. 3): descents (:mod:`vpid_peers.solver`) from
uniform starts in the box (its centre is the vehicle's truth) until the budget ends the run,
every evaluation (Jacobians included) counted by the run loop.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from vpid_bench import Bounds, ConfigError, LoopOptimizer, OptimizerParams

from .coordinates import Coordinates, Scaling
from .solver import Solver, SolverSettings


@dataclasses.dataclass(frozen=True)
class LSQParams(OptimizerParams):
    """``scaling`` (:mod:`vpid_peers.coordinates`), ``broyden``, ``inner``, ``fd_step``,
    ``ftol`` (:class:`~vpid_peers.solver.SolverSettings`); ``ps``, ``iterations`` unused."""

    scaling: Scaling = "auto"
    broyden: bool = True
    inner: int = 1
    fd_step: float = 1e-7
    ftol: float = 1e-10

    def __post_init__(self) -> None:
        if self.inner < 1:
            raise ConfigError("optimizer.inner", self.inner, "an integer >= 1")
        if not 0.0 < self.fd_step < 0.1:
            raise ConfigError("optimizer.fd_step", self.fd_step, "a number in (0, 0.1)")
        if not 0.0 < self.ftol < 1.0:
            raise ConfigError("optimizer.ftol", self.ftol, "a number in (0, 1)")


def check_scaling(params: LSQParams, bounds: Bounds) -> None:
    """``scaling=log`` needs a box with positive lower bounds."""
    if params.scaling == "log" and not np.all(bounds.lower > 0):
        raise ConfigError("optimizer.scaling", "log", "auto or box: the box has lower bounds <= 0")


def multistart(
    evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    params: LSQParams,
    bounds: Bounds,
    groups: np.ndarray,
    rng: np.random.Generator,
    first: np.ndarray | None = None,
) -> None:
    """Descents from ``first`` (when given), then from uniform random points until the budget
    (``scaling`` checked by the optimizer when built)."""
    coords = Coordinates(bounds, params.scaling)
    solver = Solver(evaluate, coords, groups, SolverSettings(
        fd_step=params.fd_step, inner=params.inner, broyden=params.broyden, ftol=params.ftol))
    x0 = first
    while True:
        if x0 is None:
            x0 = bounds.sample(rng, 1)[0]
        solver.descend(coords.to_u(x0))
        x0 = None


class LeastSquares(LoopOptimizer):
    """Multistart IRLS trust-region least squares on the problem's residuals."""

    Params = LSQParams
    library = "scipy"
    wants_residuals = True

    def __init__(self, params: LSQParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        check_scaling(params, bounds)

    def minimize(self, evaluate: Callable[[np.ndarray], Any]) -> None:
        if self.residual_groups is None:
            raise RuntimeError("lsq needs residual_groups: run it through vpid_bench.runner.run")
        multistart(evaluate, self.params, self.bounds, self.residual_groups, self.rng)
