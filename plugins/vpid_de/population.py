"""The adaptive DEs' external archive and L-SHADE's linear population size reduction."""

from __future__ import annotations

import math

import numpy as np


class Archive:
    """Parents that lost to their trial (JADE), up to ``capacity`` rows (random deletion)."""

    def __init__(self, capacity: int, dim: int) -> None:
        self.capacity = int(capacity)
        self.rows = np.empty((0, dim))

    def __len__(self) -> int:
        return self.rows.shape[0]

    def add(self, X: np.ndarray, rng: np.random.Generator) -> None:
        """Insert the rows of ``X``, then delete random rows down to the capacity."""
        if len(X):
            self.rows = np.vstack([self.rows, X])
        self._fit(rng)

    def resize(self, capacity: int, rng: np.random.Generator) -> None:
        """Set a new capacity and delete random rows down to it."""
        self.capacity = int(capacity)
        self._fit(rng)

    def _fit(self, rng: np.random.Generator) -> None:
        if len(self) > self.capacity:
            keep = np.sort(rng.choice(len(self), size=self.capacity, replace=False))
            self.rows = self.rows[keep]


def round_half_up(x: float) -> int:
    """Round half up (C's ``round`` for positive values; Python's sends 2.5 to 2)."""
    return int(math.floor(x + 0.5))


def lpsr_size(nfe: int, max_nfe: int, n_init: int, n_min: int) -> int:
    """L-SHADE's planned size after ``nfe`` of ``max_nfe`` evaluations (Eq. 10), >= n_min."""
    return max(n_min, round_half_up((n_min - n_init) / max_nfe * nfe + n_init))


def worst_removed(X: np.ndarray, f: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The population without its ``len(X) - n`` worst (ties: the later first), order kept."""
    if n >= len(X):
        return X, f
    keep = np.sort(np.argsort(f, kind="stable")[:n])
    return X[keep], f[keep]
