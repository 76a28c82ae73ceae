"""``problem=lateral_mf``: the single-track model with a Magic Formula tyre per axle,
``Fy = D sin(C atan(B a - E (B a - atan(B a))))``, by RK4 (:func:`.kernel.mf_single_track`).
Known: ``m``, ``L``, ``lf``, ``E``; identified ``Bf, Cf, Df, Br, Cr, Dr, Iz``, the shape factors
capped at 1.99 (``C < 2``). The parameter set ``civic_mf`` is ours, derived from
:mod:`.lateral`'s car and a published tyre file (docs/suite.md, "problem=lateral_mf").
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from .model import RideModel
from .problem import RideProblem
from .steering import SteeredConfig, SteeredRecord

G = 9.81  # m/s^2
#: PAC2002 lateral coefficients of the 185/80R14 tyre file published with Project Chrono:
#: shape factor (PCY1), friction (PDY1), curvature (PEY1).
SHAPE, MU, CURVATURE = 1.4675, 0.94, 0.004


def _civic_mf() -> dict[str, float]:
    m, L, lf, mu, C, E = 1462.0, 2.70, 1.08, MU, SHAPE, CURVATURE
    fz_f, fz_r = m * G * (L - lf) / L, m * G * lf / L
    Df, Dr = mu * fz_f, mu * fz_r
    return {"Bf": 192150.0 / (C * Df), "Cf": C, "Df": Df,
            "Br": 202500.0 / (C * Dr), "Cr": C, "Dr": Dr, "Iz": 2500.0,
            "m": m, "L": L, "lf": lf, "E": E}


class MagicSingleTrack(SteeredRecord, RideModel):
    names = ("Bf", "Cf", "Df", "Br", "Cr", "Dr", "Iz")
    units = ("1/rad", "1", "N", "1/rad", "1", "N", "kg m²")
    sets = {"civic_mf": _civic_mf()}

    def physical(self, X: np.ndarray, known: dict[str, float]) -> np.ndarray:
        """Positive parameters, and shape factors C in (0, 2) (beyond 2 the curve folds)."""
        ok = np.all(np.isfinite(X) & (X > 0), axis=1)
        return ok & (X[:, 1] < 2) & (X[:, 4] < 2)

    def box(self, nominal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``[0.5, 1.5] x`` the set, the shape factors capped at 1.99 (C < 2)."""
        lower, upper = 0.5 * nominal, 1.5 * nominal
        upper[[1, 4]] = np.minimum(upper[[1, 4]], 1.99)
        return lower, upper

    def simulate(self, X: np.ndarray, known: dict[str, float], sensors: str, u: np.ndarray,
                 dt: float, solver: str) -> np.ndarray:
        from .kernel import mf_single_track

        X = np.atleast_2d(np.asarray(X, dtype=float))
        n = X.shape[0]
        # The kernel runs 4 candidates at a time and the rest one by one, each with the same
        # arithmetic; a rest of 2 or 3 is cheaper as one more block of 4 (the last row again).
        if n % 4 >= 2:
            X = np.concatenate([X, np.repeat(X[-1:], 4 - n % 4, axis=0)])
        y = np.empty((u.shape[0], 3, X.shape[0]))
        lf = known["lf"]
        mf_single_track(np.ascontiguousarray(X[:, :6].T), np.ascontiguousarray(X[:, 6]),
                        np.ascontiguousarray(u[:, 0], dtype=float), dt, known["m"], lf,
                        known["L"] - lf, self.vx, known["E"], y)
        keep = [{"r": 0, "ay": 1, "beta": 2}[c] for c, _ in self.sensors[sensors]]
        return y[:, keep, :n].transpose(2, 0, 1)


@dataclasses.dataclass(frozen=True)
class LateralMFConfig(SteeredConfig):
    """As :class:`.lateral.LateralConfig`; 4 degrees by default (the tyres' nonlinear range)."""

    parameter_set: Literal["civic_mf"] = "civic_mf"
    steer_deg: float = 4.0
    MAX_STEER = (15.0, "")
    Model = MagicSingleTrack


class LateralMFProblem(RideProblem):
    """The Magic Formula single-track model identified from a steering manoeuvre."""

    Config = LateralMFConfig
    name = "lateral_mf"
    family = "single-track lateral, Magic Formula"
    model = MagicSingleTrack()

    def __init__(self, config: LateralMFConfig, index: int = 0) -> None:
        self.model = MagicSingleTrack(config.speed_kmh / 3.6)
        super().__init__(config, index)
