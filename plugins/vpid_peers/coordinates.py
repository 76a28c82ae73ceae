"""The coordinates the peers step in: the vehicle's parameters span five decades (kg to N/m)
and its box is ``[0.5, 1.5]`` times the truth, so a step in physical units is badly scaled.
The least-squares solver's :class:`Coordinates`: ``log``, ``u = ln(x / x_mid)`` (``x_mid`` the
geometric mean of the bounds: a step of 0.01 is a 1 % change; needs ``lower > 0``), or
``box``, ``u = (x - lower) / (upper - lower)``; the libraries' unit cube, :func:`to_physical`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from vpid_bench import Bounds

Scaling = Literal["auto", "log", "box"]


class Coordinates:
    """Rows between physical units and the solver's ``u`` (``auto``: ``log`` if lower > 0)."""

    def __init__(self, bounds: Bounds, kind: Scaling = "auto") -> None:
        positive = bool(np.all(bounds.lower > 0))
        if kind == "auto":
            kind = "log" if positive else "box"
        if kind == "log" and not positive:
            raise ValueError("log coordinates need a box with lower bounds > 0")
        self.kind = kind
        self.bounds = bounds
        if kind == "log":
            self._mid = np.sqrt(bounds.lower * bounds.upper)
        self.lower = self.to_u(bounds.lower)
        self.upper = self.to_u(bounds.upper)

    def to_u(self, X: np.ndarray) -> np.ndarray:
        """Physical rows (or one vector) to solver coordinates."""
        X = np.asarray(X, dtype=float)
        if self.kind == "log":
            return np.log(X / self._mid)
        return (X - self.bounds.lower) / self.bounds.width

    def to_x(self, U: np.ndarray) -> np.ndarray:
        """Solver coordinates to physical rows, clipped into the box (against rounding)."""
        U = np.asarray(U, dtype=float)
        if self.kind == "log":
            X = self._mid * np.exp(U)
        else:
            X = self.bounds.lower + U * self.bounds.width
        return np.clip(X, self.bounds.lower, self.bounds.upper)


def to_physical(U: np.ndarray, bounds: Bounds) -> np.ndarray:
    """The unit cube's rows (a library's step means the same for every parameter) in
    physical units, ``lower + U width``, clipped (``U = 1`` may round one ulp outside)."""
    X = bounds.lower + np.asarray(U, dtype=float) * bounds.width
    return np.minimum(np.maximum(X, bounds.lower), bounds.upper)
