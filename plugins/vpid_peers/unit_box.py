"""The unit cube the peers search in: a library's step means the same for every parameter
(the vehicle's differ by six orders of magnitude)."""

from __future__ import annotations

import numpy as np

from vpid_bench import Bounds


def to_physical(U: np.ndarray, bounds: Bounds) -> np.ndarray:
    """``lower + U width``, clipped to the box (``U = 1`` may round one ulp outside)."""
    X = bounds.lower + np.asarray(U, dtype=float) * bounds.width
    return np.minimum(np.maximum(X, bounds.lower), bounds.upper)


def library_available(module: str) -> bool:
    """True when ``module`` can be imported; finds it without importing it (milliseconds)."""
    import importlib.util

    return importlib.util.find_spec(module) is not None
