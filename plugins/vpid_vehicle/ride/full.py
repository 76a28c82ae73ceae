"""``problem=ride_full``: the full car (7-DOF) from a record over two road tracks (docs/suite.md).

``q = [z, phi, theta, zFL, zFR, zRL, zRR]``: bounce (m), roll (rad, left side up), pitch
(rad, rear up) and the wheel hops (m); a body point ``x`` ahead of and ``y`` left of the
centre of gravity moves as ``z - x theta + y phi``. ``K = J^T diag(k) J``, ``C = J^T diag(c)
J`` on the elongations ``e = J q``, with a front anti-roll bar ``kR`` (N m/rad) on ``phi -
(zFL - zFR) / (yL + yR)``.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from . import linear
from .model import RideModel, Suspension, Wheel
from .problem import RideConfig, RideProblem

#: Jazar, Vehicle Dynamics (full-car example): yL, yR are the distances from the centre of
#: gravity to the left and right wheels (track 1.45 m, CG 0.025 m off centre).
JAZAR = {"m": 840.0, "Ix": 820.0, "Iy": 1100.0, "mf": 53.0, "mr": 76.0, "kf": 10000.0,
         "kr": 13000.0, "cf": 5000.0, "cr": 5000.0, "a1": 1.4, "a2": 1.47, "yL": 0.7,
         "yR": 0.75, "kt": 200000.0, "kR": 10000.0}
#: Wheel order of the degrees of freedom 3..6 and of the inputs.
WHEELS = ("FL", "FR", "RL", "RR")


def _geometry(known: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """x (forward) and y (left) of each wheel relative to the centre of gravity (m)."""
    a1, a2, yl, yr = known["a1"], known["a2"], known["yL"], known["yR"]
    return np.array([a1, a1, -a2, -a2]), np.array([yl, -yr, yl, -yr])


def full_car_matrices(X: np.ndarray, known: dict[str, float]
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``M, C, K`` ``(n, 7, 7)`` and ``F`` ``(n, 7, 8)`` (heights, then rates, FL, FR, RL, RR)."""
    X = np.atleast_2d(X)
    n = X.shape[0]
    m, Ix, Iy, mf, mr, kf, kr, cf, cr = X.T
    xs, ys = _geometry(known)
    # elongations: 4 suspensions (body corner - wheel), 4 tyres (wheel), 1 anti-roll bar
    J = np.zeros((9, 7))
    for i in range(4):
        J[i, 0], J[i, 1], J[i, 2], J[i, 3 + i] = 1.0, ys[i], -xs[i], -1.0
        J[4 + i, 3 + i] = 1.0
    track = known["yL"] + known["yR"]
    J[8, 1], J[8, 3], J[8, 4] = 1.0, -1.0 / track, 1.0 / track
    ones = np.ones(n)
    k = np.stack([kf, kf, kr, kr, *(known["kt"] * ones,) * 4, known["kR"] * ones], axis=1)
    c = np.stack([cf, cf, cr, cr, *(np.zeros(n),) * 5], axis=1)
    K = J.T @ (k[:, :, None] * J)
    C = J.T @ (c[:, :, None] * J)
    M = np.zeros((n, 7, 7))
    for j, v in enumerate((m, Ix, Iy, mf, mf, mr, mr)):
        M[:, j, j] = v
    F = np.zeros((n, 7, 8))
    for i in range(4):
        F[:, 3 + i, i] = known["kt"]
    return M, C, K, F


def _suspension_rows(X: np.ndarray, known: dict[str, float]) -> np.ndarray:
    """The four suspensions' elongation rows ``(n, 4, 7)`` (FL, FR, RL, RR)."""
    xs, ys = _geometry(known)
    J = np.zeros((X.shape[0], 4, 7))
    for i in range(4):
        J[:, i, 0], J[:, i, 1], J[:, i, 2], J[:, i, 3 + i] = 1.0, ys[i], -xs[i], -1.0
    return J


class FullCar(RideModel):
    suspension = Suspension((("kf", "cf"), ("kr", "cr")), (0, 0, 1, 1), _suspension_rows)
    wheel_names = ("h_FL", "h_FR", "h_RL", "h_RR")
    names = ("m", "Ix", "Iy", "mf", "mr", "kf", "kr", "cf", "cr")
    units = ("kg", "kg m²", "kg m²", "kg", "kg", "N/m", "N/m", "N s/m", "N s/m")
    sets = {
        "jazar": JAZAR,
        # the same car with its centre of gravity on the centre line (yL = yR = 0.725 m): it
        # reduces to a half car with per-axle values on identical tracks
        "jazar_symmetric": {**JAZAR, "yL": 0.725, "yR": 0.725},
        # CommonRoad vehicle models 3.0.2, parameters_vehicle2.yaml (BMW 320i; BSD-3), read
        # as docs/suite.md's table of the sets says
        "bmw320i": {"m": 965.7108, "Ix": 207.2652, "Iy": 1565.8179, "mf": 31.8961,
                    "mr": 31.8961, "kf": 24453.1379, "kr": 19635.5047, "cf": 1786.2441,
                    "cr": 1649.0833, "a1": 1.1562, "a2": 1.4227, "yL": 0.68771,
                    "yR": 0.68771, "kt": 158294.1398, "kR": 0.0},
    }
    sensors = {
        "body": tuple((f"b{w}''", "m/s²") for w in WHEELS),
        "body_wheel": (*((f"b{w}''", "m/s²") for w in WHEELS),
                       *((f"w{w}''", "m/s²") for w in WHEELS)),
        "body_rates": (*((f"b{w}''", "m/s²") for w in WHEELS), ("phi'", "rad/s"),
                       ("theta'", "rad/s")),
    }

    def wheels(self, known: dict[str, float], speed: float) -> tuple[Wheel, ...]:
        lag = (known["a1"] + known["a2"]) / speed
        return (Wheel(0, 0.0), Wheel(1, 0.0), Wheel(0, lag), Wheel(1, lag))

    def system(self, X: np.ndarray, known: dict[str, float], sensors: str
               ) -> linear.LinearSystem:
        M, C, K, F = full_car_matrices(X, known)
        xs, ys = _geometry(known)
        names = [c for c, _ in self.sensors[sensors]]
        Pa = np.zeros((len(names), 7))
        Pv = np.zeros((len(names), 7))
        for j, c in enumerate(names):
            if c.startswith("b"):
                i = WHEELS.index(c[1:3])
                Pa[j, 0], Pa[j, 1], Pa[j, 2] = 1.0, ys[i], -xs[i]
            elif c.startswith("w"):
                Pa[j, 3 + WHEELS.index(c[1:3])] = 1.0
            else:
                Pv[j, 1 if c == "phi'" else 2] = 1.0
        return linear.LinearSystem(M, C, K, F, Pa, np.zeros((len(names), 7)),
                                   np.zeros((len(names), 8)), Pv)


@dataclasses.dataclass(frozen=True)
class RideFullConfig(RideConfig):
    """``parameter_set``, ``sensors``; the rest: :class:`.problem.RideConfig`."""

    parameter_set: Literal["jazar", "jazar_symmetric", "bmw320i"] = "jazar"
    sensors: Literal["body", "body_wheel", "body_rates"] = "body"
    Model = FullCar


class RideFullProblem(RideProblem):
    """The full car identified from a two-track road record."""

    Config = RideFullConfig
    name = "ride_full"
    family = "full car"
    model = FullCar()
