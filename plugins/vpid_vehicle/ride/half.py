"""``problem=ride_half``: the paper's half car (``q = [x, theta, x1, x2]``, M, C, K of Eq. 2,
:func:`vpid_vehicle.model.matrices`) with the suite's record, noise, random truth, roads and
sensors (docs/suite.md); the rear wheel on the front's track ``L / speed`` later.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from vpid_bench import added_setting

from ..config import VehicleParams
from ..model import KnownConstants, matrices, tyre_input
from . import linear
from .model import RideModel, Suspension, Wheel
from .problem import RideConfig, RideProblem


def _suspension_rows(X: np.ndarray, known: dict[str, float]) -> np.ndarray:
    """The two suspensions' elongation rows ``(n, 2, 4)`` (front, rear) of the rows ``X``."""
    a1 = X[:, 8]
    J = np.zeros((X.shape[0], 2, 4))
    J[:, 0, 0], J[:, 0, 1], J[:, 0, 2] = 1.0, -a1, -1.0
    J[:, 1, 0], J[:, 1, 1], J[:, 1, 3] = 1.0, known["L"] - a1, -1.0
    return J


class HalfCar(RideModel):
    suspension = Suspension((("k1", "c1"), ("k2", "c2")), (0, 1), _suspension_rows)
    wheel_names = ("h1", "h2")
    names = ("m", "I", "m1", "m2", "k1", "k2", "c1", "c2", "a1")
    units = ("kg", "kg m²", "kg", "kg", "N/m", "N/m", "N s/m", "N s/m", "m")
    sets = {
        # Gökdağ (2014), the paper's vehicle (the truth of problem=vehicle)
        "gokdag": dataclasses.asdict(VehicleParams()),
        # one side of Jazar's full car (Vehicle Dynamics): half the sprung mass with half its
        # pitch inertia (1100 / 2), per-corner springs, dampers and tyres
        "jazar_half": {"m": 420.0, "I": 550.0, "m1": 53.0, "m2": 76.0, "k1": 10000.0,
                       "k2": 13000.0, "c1": 5000.0, "c2": 5000.0, "a1": 1.4,
                       "L": 2.87, "kt1": 200000.0, "kt2": 200000.0},
    }
    sensors = {
        "body": (("z1''", "m/s²"), ("z2''", "m/s²")),
        "body_wheel": (("z1''", "m/s²"), ("z2''", "m/s²"), ("x1''", "m/s²"), ("x2''", "m/s²")),
        "body_pitch_rate": (("z1''", "m/s²"), ("z2''", "m/s²"), ("theta'", "rad/s")),
    }

    def wheels(self, known: dict[str, float], speed: float) -> tuple[Wheel, ...]:
        return (Wheel(0, 0.0), Wheel(0, known["L"] / speed))

    def system(self, X: np.ndarray, known: dict[str, float], sensors: str
               ) -> linear.LinearSystem:
        X = np.atleast_2d(X)
        n = X.shape[0]
        k = KnownConstants(known["L"], known["kt1"], known["kt2"])
        M, C, K = matrices(X, k)
        F = np.zeros((n, 4, 4))
        F[:, :, :2] = tyre_input(k)
        a1, a2 = X[:, 8], known["L"] - X[:, 8]
        names = [c for c, _ in self.sensors[sensors]]
        Pa = np.zeros((n, len(names), 4))
        Pv = np.zeros((n, len(names), 4))
        for j, c in enumerate(names):
            if c == "z1''":
                Pa[:, j, 0], Pa[:, j, 1] = 1.0, -a1
            elif c == "z2''":
                Pa[:, j, 0], Pa[:, j, 1] = 1.0, a2
            elif c == "x1''":
                Pa[:, j, 2] = 1.0
            elif c == "x2''":
                Pa[:, j, 3] = 1.0
            else:  # theta'
                Pv[:, j, 1] = 1.0
        return linear.LinearSystem(M, C, K, F, Pa, np.zeros((len(names), 4)),
                                   np.zeros((len(names), 4)), Pv)


@dataclasses.dataclass(frozen=True)
class RideHalfConfig(RideConfig):
    """``parameter_set``, ``sensors``, ``record_model``; the rest: :class:`.problem.RideConfig`."""

    parameter_set: Literal["gokdag", "jazar_half"] = "gokdag"
    sensors: Literal["body", "body_wheel", "body_pitch_rate"] = "body"
    record_model: Literal["linear", "seat"] = added_setting("linear")
    Model = HalfCar


class RideHalfProblem(RideProblem):
    """The half car identified from a road record."""

    Config = RideHalfConfig
    name = "ride_half"
    family = "half car"
    model = HalfCar()

    def _record(self, fine_u: np.ndarray, sub: int) -> np.ndarray:
        """The record; the seated car's with ``record_model=seat`` (exact, first-order hold)."""
        if self.config.record_model == "linear":
            return super()._record(fine_u, sub)
        from .richer import seated_half

        system = seated_half(self.model.system(self._x_true[None], self.known,
                                               self.config.sensors))
        y = linear.simulate(linear.exact_foh(system, self.config.dt / sub), fine_u)
        return y[0, ::sub].T
