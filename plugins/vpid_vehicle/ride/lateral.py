"""``problem=lateral``: a car's cornering stiffnesses, yaw inertia and centre of gravity from
a steering manoeuvre (docs/suite.md): the linear single-track model at constant ``vx``, ``af
= delta - (vy + lf r) / vx``, ``ar = -(vy - lr r) / vx`` (SI units, small angles),

    m (vy' + vx r) = Cf af + Cr ar,      Iz r' = lf Cf af - lr Cr ar

on the core's form with ``q' = [vy, r]`` (``K = 0``); outputs ``r``, ``ay = vy' + vx r``,
``beta = vy / vx``. ``record_model=magic_formula``: the record by :mod:`.magic`'s model.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from . import linear
from .magic import CURVATURE, MU, SHAPE, MagicSingleTrack
from .model import RideModel
from .problem import RideProblem
from .steering import SteeredConfig, SteeredRecord


class SingleTrack(SteeredRecord, RideModel):
    names = ("Cf", "Cr", "Iz", "lf")
    units = ("N/rad", "N/rad", "kg m²", "m")
    sets = {
        # the reference car of openpilot's vehicle models (Honda Civic 2016 with 136 kg of
        # cargo): axle cornering stiffnesses, understeering
        "civic": {"Cf": 192150.0, "Cr": 202500.0, "Iz": 2500.0, "lf": 1.08,
                  "m": 1462.0, "L": 2.70},
        # MCC Smart ("Modellbildung und Simulation in der Fahrzeugtechnik", 2012, as cited in
        # public code): oversteering, critical speed 35.8 m/s
        "smart": {"Cf": 70000.0, "Cr": 90000.0, "Iz": 3000.0, "lf": 1.142,
                  "m": 820.0, "L": 1.812},
    }
    def system(self, X: np.ndarray, known: dict[str, float], sensors: str,
               vx: float | None = None) -> linear.LinearSystem:
        """The systems at ``vx`` m/s (default: the model's speed)."""
        vx = self.vx if vx is None else vx
        X = np.atleast_2d(X)
        n = X.shape[0]
        Cf, Cr, Iz, lf = X.T
        lr, m = known["L"] - lf, known["m"]
        M = np.zeros((n, 2, 2))
        M[:, 0, 0], M[:, 1, 1] = m, Iz
        C = np.empty((n, 2, 2))
        C[:, 0, 0] = (Cf + Cr) / vx
        C[:, 0, 1] = m * vx + (lf * Cf - lr * Cr) / vx
        C[:, 1, 0] = (lf * Cf - lr * Cr) / vx
        C[:, 1, 1] = (lf**2 * Cf + lr**2 * Cr) / vx
        F = np.stack([Cf, lf * Cf], axis=1)[:, :, None]
        names = [c for c, _ in self.sensors[sensors]]
        Pa = np.zeros((len(names), 2))
        Pv = np.zeros((len(names), 2))
        for j, c in enumerate(names):
            if c == "r":
                Pv[j, 1] = 1.0
            elif c == "ay":
                Pa[j, 0], Pv[j, 1] = 1.0, vx
            else:  # beta
                Pv[j, 0] = 1.0 / vx
        return linear.LinearSystem(M, C, np.zeros((n, 2, 2)), F, Pa, np.zeros((len(names), 2)),
                                   np.zeros((len(names), 1)), Pv)


@dataclasses.dataclass(frozen=True)
class LateralConfig(SteeredConfig):
    """``parameter_set``, ``record_model``; the rest: :class:`.steering.SteeredConfig`."""

    parameter_set: Literal["civic", "smart"] = "civic"
    record_model: Literal["linear", "magic_formula"] = "linear"
    Model = SingleTrack


class LateralProblem(RideProblem):
    """The linear single-track model identified from a steering manoeuvre."""

    Config = LateralConfig
    name = "lateral"
    family = "single-track lateral"
    model = SingleTrack()

    def __init__(self, config: LateralConfig, index: int = 0) -> None:
        self.model = SingleTrack(config.speed_kmh / 3.6)
        super().__init__(config, index)

    def _record(self, fine_u: np.ndarray, sub: int) -> np.ndarray:
        """The record; the Magic Formula model's with ``record_model=magic_formula``."""
        if self.config.record_model == "linear":
            return super()._record(fine_u, sub)
        Cf, Cr, Iz, lf = self._x_true
        m, L = self.known["m"], self.known["L"]
        Df, Dr = MU * m * 9.81 * (L - lf) / L, MU * m * 9.81 * lf / L
        X = np.array([[Cf / (SHAPE * Df), SHAPE, Df, Cr / (SHAPE * Dr), SHAPE, Dr, Iz]])
        known = {"m": m, "L": L, "lf": lf, "E": CURVATURE}
        mf = MagicSingleTrack(self.config.speed_kmh / 3.6)
        y = mf.simulate(X, known, self.config.sensors, fine_u, self.config.dt / sub, "exact")
        return y[0, ::sub].T


def steady_yaw_gain(X: np.ndarray, known: dict[str, float], vx: float) -> np.ndarray:
    """``r / delta`` in steady state (1/s): ``vx / (L + K vx^2)``, ``K`` the understeer gradient."""
    Cf, Cr, _, lf = np.atleast_2d(X).T
    L, m = known["L"], known["m"]
    K = m / L * ((L - lf) / Cf - lf / Cr)
    return vx / (L + K * vx**2)
