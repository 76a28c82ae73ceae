"""The normalised coordinates the peers search in: the box mapped onto the unit cube.

A library's step size or bounds then mean the same for every parameter (the vehicle's masses,
stiffnesses and lengths differ by six orders of magnitude), and its candidates come back to
physical units through one affine map.
"""

from __future__ import annotations

import numpy as np

from vpid_bench import Bounds


def to_physical(U: np.ndarray, bounds: Bounds) -> np.ndarray:
    """Unit-cube rows ``U`` in physical units, ``lower + U * width``.

    The result is clipped to the box: a library that keeps ``U`` in ``[0, 1]`` can still land
    one rounding error outside ``[lower, upper]`` through the multiplication (``U = 1``).
    """
    X = bounds.lower + np.asarray(U, dtype=float) * bounds.width
    return np.minimum(np.maximum(X, bounds.lower), bounds.upper)


def library_available(module: str) -> bool:
    """True when ``module`` can be imported; finds it without importing it (milliseconds)."""
    import importlib.util

    return importlib.util.find_spec(module) is not None
