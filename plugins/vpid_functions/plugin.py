"""``problem=functions``: sphere, Rosenbrock and Rastrigin in ``dim`` dimensions, cheap, and
proof that the core knows no vehicle. ``x_true`` only where no coordinate is zero (NoRE is
undefined there); each a sum of squares whose terms ``residuals`` returns (one group), for
least-squares optimizers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from vpid_bench import Bounds, ConfigError, Problem, ProblemConfig, hookimpl


def sphere(X: np.ndarray) -> np.ndarray:
    """sum(x^2); minimum 0 at x = 0."""
    return np.sum(X * X, axis=1)


def rosenbrock(X: np.ndarray) -> np.ndarray:
    """sum(100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2); minimum 0 at x = 1."""
    return np.sum(100.0 * (X[:, 1:] - X[:, :-1] ** 2) ** 2 + (1.0 - X[:, :-1]) ** 2, axis=1)


def rastrigin(X: np.ndarray) -> np.ndarray:
    """10 d + sum(x^2 - 10 cos(2 pi x)); minimum 0 at x = 0."""
    return 10.0 * X.shape[1] + np.sum(X * X - 10.0 * np.cos(2.0 * np.pi * X), axis=1)


#: Residuals whose sum of squares is each function: x; 10 (x_{i+1} - x_i^2) then 1 - x_i;
#: sqrt(10 + x^2 - 10 cos(2 pi x)) (the radicand is >= x^2 >= 0).
RESIDUALS = {
    "sphere": lambda X: X.copy(),
    "rosenbrock": lambda X: np.hstack([10.0 * (X[:, 1:] - X[:, :-1] ** 2), 1.0 - X[:, :-1]]),
    "rastrigin": lambda X: np.sqrt(np.maximum(10.0 + X * X - 10.0 * np.cos(2.0 * np.pi * X),
                                              0.0)),
}

FUNCTIONS = {
    # name: (function, default half-width of the box, minimiser coordinate)
    "sphere": (sphere, 5.12, 0.0),
    "rosenbrock": (rosenbrock, 5.0, 1.0),
    "rastrigin": (rastrigin, 5.12, 0.0),
}


@dataclass(frozen=True)
class FunctionsConfig(ProblemConfig):
    """``function``: sphere, rosenbrock or rastrigin; ``dim``: number of variables;
    ``half_width``: the box is [-half_width, half_width]^dim (null: the function's usual box)."""

    function: Literal["sphere", "rosenbrock", "rastrigin"] = "sphere"
    dim: int = 10
    half_width: float | None = None

    def __post_init__(self) -> None:
        if not 2 <= self.dim <= 10_000:
            raise ConfigError("problem.dim", self.dim, "an integer from 2 to 10000")
        hw = self.half_width
        if hw is not None and not (math.isfinite(hw) and 0 < hw <= 1e150):
            raise ConfigError("problem.half_width", hw, "a positive number up to 1e150 or "
                              "null (the function's usual box)")


class FunctionsProblem(Problem):
    """A test function over a symmetric box."""

    Config = FunctionsConfig
    rows_independent = True  # row-wise numpy: a row's value ignores the rest of the batch
    fits_a_record = False  # residuals serve least squares; there is no record to identify

    def __init__(self, config: FunctionsConfig) -> None:
        super().__init__(config)
        self._f, default_hw, self._opt = FUNCTIONS[config.function]
        hw = default_hw if config.half_width is None else config.half_width
        names = tuple(f"x{i + 1}" for i in range(config.dim))
        self._bounds = Bounds(np.full(config.dim, -hw), np.full(config.dim, hw), names)

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    @property
    def x_true(self) -> np.ndarray | None:
        return None if self._opt == 0.0 else np.full(self.config.dim, self._opt)

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        return self._f(np.atleast_2d(np.asarray(X, dtype=float)))

    def residuals(self, X: np.ndarray) -> np.ndarray:
        """Residuals whose sum of squares is the function (one group), ``(n, m)``."""
        return RESIDUALS[self.config.function](np.atleast_2d(np.asarray(X, dtype=float)))

    def residual_groups(self) -> np.ndarray:
        m = 2 * (self.config.dim - 1) if self.config.function == "rosenbrock" else self.config.dim
        return np.zeros(m, dtype=int)

    def describe(self) -> dict:
        return {"f_min": 0.0, "x_min": float(self._opt)}


@hookimpl
def vpid_bench_register_problems(register):
    register("functions", FunctionsProblem)
