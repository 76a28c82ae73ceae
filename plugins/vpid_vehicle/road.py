"""The road input: a rectangular bump met by the front tyre at t = 0 and by the rear tyre
``L / V`` later (s, m), sampled on ``t_k = k dt`` for the integrator: ``point`` (``y(t_k)``,
edges judged with a 1e-9 s tolerance; first order) or ``average`` (each Newmark step receives
the exact impulse of the step's mean; second order, needs ``gamma >= 1/2``). Why and how
accurate: docs/vehicle.md, "Input and record window"; docs/paper-notes.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Tolerance (s) for comparing grid times with bump edges.
TIME_TOL = 1e-9


@dataclass(frozen=True)
class Bump:
    """Where the bump is under each tyre: ``y_i(t) = h`` for ``on_i <= t < off_i`` (s, m)."""

    h: float
    front_on: float
    front_off: float
    rear_on: float
    rear_off: float

    @classmethod
    def from_geometry(cls, V_kmh: float, h: float, w: float, L: float) -> Bump:
        """Bump ``h`` x ``w`` (m) crossed at ``V_kmh`` km/h by a car of wheelbase ``L`` (m)."""
        v = V_kmh / 3.6
        return cls(h=h, front_on=0.0, front_off=w / v, rear_on=L / v, rear_off=(L + w) / v)

    @property
    def windows(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """``((front_on, front_off), (rear_on, rear_off))`` in s."""
        return (self.front_on, self.front_off), (self.rear_on, self.rear_off)

    @property
    def edges(self) -> tuple[float, ...]:
        """Times (s) where the input jumps."""
        return (self.front_on, self.front_off, self.rear_on, self.rear_off)

    def value(self, t: np.ndarray) -> np.ndarray:
        """``[y1(t), y2(t)]`` with the exact edges (no tolerance), shape ``(len(t), 2)``."""
        t = np.asarray(t, dtype=float)
        return np.stack([self.h * ((t >= a) & (t < b)) for a, b in self.windows], axis=-1)


def time_grid(T: float, dt: float) -> np.ndarray:
    """``t_k = k dt`` for ``k = 0 ... floor(T / dt)`` (s); T is the window length in s."""
    n = int(np.floor((T + TIME_TOL) / dt)) + 1
    return np.arange(n) * dt


def sample_point(bump: Bump, t: np.ndarray) -> np.ndarray:
    """``y(t_k)`` with tolerant edges; shape ``(len(t), 2)`` (m)."""
    t = np.asarray(t, dtype=float)
    cols = [bump.h * ((t >= a - TIME_TOL) & (t < b - TIME_TOL)) for a, b in bump.windows]
    return np.stack(cols, axis=-1)


def sample(bump: Bump, t: np.ndarray, mode: str, gamma: float = 0.5) -> np.ndarray:
    """The input as Newmark sees it, ``(len(t), 2)`` (m): ``point`` (:func:`sample_point`) or
    ``average``, ``y_0 = y(0)``, ``y_{k+1} = (mean_k - (1 - gamma) y_k) / gamma`` (Newmark's
    velocity update integrates ``dt ((1 - gamma) y_k + gamma y_{k+1})``: the step's exact
    impulse)."""
    if mode == "point":
        return sample_point(bump, t)
    if mode != "average":
        raise ValueError(f"unknown sampling {mode!r}: expected 'point' or 'average'")
    if not gamma >= 0.5:
        raise ValueError(f"average sampling needs gamma >= 1/2, got {gamma}")
    t = np.asarray(t, dtype=float)
    lo, hi = t[:-1], t[1:]  # the exact mean of y over each step, (len(t) - 1, 2)
    means = np.stack([bump.h * np.clip(np.minimum(hi, b) - np.maximum(lo, a), 0.0, None)
                      / (hi - lo) for a, b in bump.windows], axis=-1).reshape(len(lo), 2)
    y = np.empty((len(t), 2))
    y[0] = sample_point(bump, np.asarray(t[:1], dtype=float))[0]
    for k in range(len(t) - 1):
        y[k + 1] = (means[k] - (1.0 - gamma) * y[k]) / gamma
    return y
