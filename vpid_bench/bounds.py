"""The box a problem is searched in (:class:`Bounds`), and relative errors against a truth."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from .errors import ConfigError


@dataclasses.dataclass(frozen=True)
class Bounds:
    """A box in parameter space, with names and units for every coordinate: ``lower`` and
    ``upper`` 1-D float arrays of length ``dim``, ``lower < upper`` element-wise."""

    lower: np.ndarray
    upper: np.ndarray
    names: tuple[str, ...]
    units: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        lower = np.asarray(self.lower, dtype=float).reshape(-1)
        upper = np.asarray(self.upper, dtype=float).reshape(-1)
        names = tuple(self.names)
        units = tuple(self.units) if self.units else ("",) * len(names)
        if not (lower.shape == upper.shape and len(names) == lower.size == len(units)):
            raise ValueError(f"bounds: lower {lower.shape}, upper {upper.shape}, {len(names)} "
                             f"names and {len(units)} units must all have the same length")
        if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
            raise ValueError("bounds: lower and upper must be finite")
        bad = np.flatnonzero(~(lower < upper))
        if bad.size:
            i = int(bad[0])
            raise ConfigError(f"bounds.{names[i]}", (float(lower[i]), float(upper[i])),
                              "lower bound must be strictly below the upper bound")
        lower.setflags(write=False)
        upper.setflags(write=False)
        for key, value in (("lower", lower), ("upper", upper), ("names", names), ("units", units)):
            object.__setattr__(self, key, value)

    @property
    def dim(self) -> int:
        """Number of parameters."""
        return int(self.lower.size)

    @property
    def width(self) -> np.ndarray:
        """``upper - lower``, per parameter."""
        return self.upper - self.lower

    def contains(self, X: np.ndarray) -> np.ndarray:
        """Boolean per row of ``X``: is the candidate inside the closed box?"""
        X = np.atleast_2d(X)
        return np.all((X >= self.lower) & (X <= self.upper), axis=1)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` candidates drawn uniformly in the box, shape ``(n, dim)``; never past a bound
        (``lower + u * width`` can round one ulp above ``upper``: it is clipped)."""
        X = self.lower + rng.random((n, self.dim)) * self.width
        return np.minimum(np.maximum(X, self.lower), self.upper)


def relative_errors_percent(x: Sequence[float], x_true: Sequence[float]) -> np.ndarray:
    """Relative error of each parameter, ``100 * (x - x_true) / x_true`` (percent)."""
    x_true = np.asarray(x_true, dtype=float)
    return 100.0 * (np.asarray(x, dtype=float) - x_true) / x_true
