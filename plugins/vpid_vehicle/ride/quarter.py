"""``problem=ride_quarter``: a quarter car from what it records on a road (docs/suite.md), SI
units, the tyre ``kt``, ``ct`` known:

    ms zs'' + cs (zs' - zu') + ks (zs - zu) = 0
    mu zu'' - cs (zs' - zu') - ks (zs - zu) + ct zu' + kt zu = kt h + ct h'
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from vpid_bench import added_setting

from . import linear
from .model import RideModel, Suspension, Wheel
from .problem import RideConfig, RideProblem


def _suspension_rows(X: np.ndarray, known: dict[str, float]) -> np.ndarray:
    """The suspension's elongation row ``(n, 1, 2)``: body minus wheel."""
    return np.broadcast_to(np.array([[1.0, -1.0]]), (X.shape[0], 1, 2)).copy()


class QuarterCar(RideModel):
    suspension = Suspension((("ks", "cs"),), (0,), _suspension_rows)
    wheel_names = ("h",)
    names = ("ms", "mu", "ks", "cs")
    units = ("kg", "kg", "N/m", "N s/m")
    sets = {
        # IRI golden car ratios (mu/ms 0.15, ks/ms 63.3 s^-2, cs/ms 6.0 s^-1, kt/ms 653 s^-2;
        # Sayers et al. 1986, ASTM E1926), scaled to a 250 kg corner
        "golden_car": {"ms": 250.0, "mu": 37.5, "ks": 15825.0, "cs": 1500.0,
                       "kt": 163250.0, "ct": 0.0},
        # University of Michigan Control Tutorials, "Suspension: System Modeling" (1/4 bus)
        "quarter_bus": {"ms": 2500.0, "mu": 320.0, "ks": 80000.0, "cs": 350.0,
                        "kt": 500000.0, "ct": 15020.0},
    }
    sensors = {
        "body": (("zs''", "m/s²"),),
        "body_wheel": (("zs''", "m/s²"), ("zu''", "m/s²")),
        "body_wheel_stroke": (("zs''", "m/s²"), ("zu''", "m/s²"), ("zs-zu", "m")),
    }

    def wheels(self, known: dict[str, float], speed: float) -> tuple[Wheel, ...]:
        return (Wheel(0, 0.0),)

    def system(self, X: np.ndarray, known: dict[str, float], sensors: str
               ) -> linear.LinearSystem:
        return quarter_system(X, known["kt"], known["ct"], sensors)


def quarter_system(X: np.ndarray, kt: float, ct: float, sensors: str) -> linear.LinearSystem:
    """The quarter cars of the rows ``[ms, mu, ks, cs]``; inputs ``[h, h']``."""
    X = np.atleast_2d(X)
    n = X.shape[0]
    ms, mu, ks, cs = X.T
    M = np.zeros((n, 2, 2))
    M[:, 0, 0], M[:, 1, 1] = ms, mu
    K = np.stack([np.stack([ks, -ks], -1), np.stack([-ks, ks + kt], -1)], 1)
    C = np.stack([np.stack([cs, -cs], -1), np.stack([-cs, cs + ct], -1)], 1)
    F = np.zeros((n, 2, 2))
    F[:, 1, 0], F[:, 1, 1] = kt, ct
    rows = {"zs''": ([1, 0], [0, 0]), "zu''": ([0, 1], [0, 0]), "zs-zu": ([0, 0], [1, -1])}
    names = [c for c, _ in QuarterCar.sensors[sensors]]
    Pa = np.array([rows[c][0] for c in names], dtype=float)
    Pq = np.array([rows[c][1] for c in names], dtype=float)
    return linear.LinearSystem(M, C, K, F, Pa, Pq, np.zeros((len(names), 2)))


@dataclasses.dataclass(frozen=True)
class RideQuarterConfig(RideConfig):
    """``parameter_set``, ``sensors``, ``record_model``; the rest: :class:`.problem.RideConfig`."""

    parameter_set: Literal["golden_car", "quarter_bus"] = "golden_car"
    sensors: Literal["body", "body_wheel", "body_wheel_stroke"] = "body_wheel"
    record_model: Literal["linear", "bilinear_damper"] = added_setting("linear")
    Model = QuarterCar


class RideQuarterProblem(RideProblem):
    """The quarter car identified from a road record."""

    Config = RideQuarterConfig
    name = "ride_quarter"
    family = "quarter car"
    model = QuarterCar()

    def _record(self, fine_u: np.ndarray, sub: int) -> np.ndarray:
        """The record, by the bilinear damper's RK4 with ``record_model=bilinear_damper``."""
        if self.config.record_model == "linear":
            return super()._record(fine_u, sub)
        from .richer import QUARTER_CHANNELS, bilinear_quarter

        y = bilinear_quarter(self._x_true, self.known["kt"], self.known["ct"], fine_u,
                             self.config.dt / sub)
        keep = [QUARTER_CHANNELS[c] for c, _ in self.channels]
        return y[::sub, keep].T
