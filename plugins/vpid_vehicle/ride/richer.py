"""Records made by richer models than the fitted ones (``record_model``): a misfit no parameter
vector removes, as on a measured record (how large: :mod:`.model_error`): a bilinear damper
for the quarter car (:func:`bilinear_quarter`, RK4 at the record's fine step), a seat for the
half car (:func:`seated_half`, the exact first-order hold); :data:`DESCRIPTIONS` says each.
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from . import linear

#: Rebound/compression asymmetry of the bilinear damper: ``(1 + a) / (1 - a)`` = 3.
DAMPER_ASYMMETRY = 0.5
#: The driver and seat of the ``seat`` record: mass (kg), cushion natural frequency (Hz) and
#: damping ratio on a rigid body, position ahead of the centre of gravity (m).
SEAT = {"mass_kg": 80.0, "hz": 4.5, "zeta": 0.3, "x_m": 0.3}


def seated_half(system: linear.LinearSystem, seat: dict[str, float] = SEAT
                ) -> linear.LinearSystem:
    """The half cars of ``system`` with a seat mass on a cushion (a fifth degree of freedom)."""
    n, d = system.M.shape[0], system.dof
    m = seat["mass_kg"]
    w = 2 * math.pi * seat["hz"]
    k, c = m * w**2, 2 * seat["zeta"] * m * w
    J = np.zeros(d + 1)
    J[0], J[1], J[d] = -1.0, seat["x_m"], 1.0  # zs - x + s theta
    JJ = np.outer(J, J)

    def grow(a: np.ndarray) -> np.ndarray:
        out = np.zeros((n, d + 1, d + 1))
        out[:, :d, :d] = a
        return out

    M, C, K = grow(system.M), grow(system.C), grow(system.K)
    M[:, d, d] = m
    C += c * JJ
    K += k * JJ
    F = np.concatenate([system.F, np.zeros((n, 1, system.F.shape[2]))], axis=1)

    def out_map(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else np.concatenate([a, np.zeros((*a.shape[:-1], 1))], axis=-1)

    return dataclasses.replace(system, M=M, C=C, K=K, F=F, Pa=out_map(system.Pa),
                               Pq=out_map(system.Pq), Pv=out_map(system.Pv))


@numba.njit(cache=True)
def _quarter_rates(s, h, hd, ms, mu, ks, cs, a, kt, ct, out):  # pragma: no cover - compiled
    zs, zu, vs, vu = s[0], s[1], s[2], s[3]
    v = vs - vu
    damper = cs * (1.0 + a) * v if v > 0.0 else cs * (1.0 - a) * v
    spring = ks * (zs - zu)
    tyre = kt * (zu - h) + ct * (vu - hd)
    out[0] = vs
    out[1] = vu
    out[2] = -(spring + damper) / ms
    out[3] = (spring + damper - tyre) / mu


@numba.njit(cache=True)
def _bilinear_rk4(p, kt, ct, a, u, dt, y):  # pragma: no cover - compiled
    ms, mu, ks, cs = p[0], p[1], p[2], p[3]
    s = np.zeros(4)
    tmp = np.empty(4)
    k1, k2, k3, k4 = np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    rates = np.empty(4)
    for k in range(u.shape[0]):
        _quarter_rates(s, u[k, 0], u[k, 1], ms, mu, ks, cs, a, kt, ct, rates)
        y[k, 0], y[k, 1] = rates[2], rates[3]
        y[k, 2], y[k, 3], y[k, 4] = s[0], s[1], s[0] - s[1]
        if k + 1 == u.shape[0]:
            break
        h0, h1 = u[k, 0], u[k + 1, 0]
        d0, d1 = u[k, 1], u[k + 1, 1]
        hm, dm = 0.5 * (h0 + h1), 0.5 * (d0 + d1)
        _quarter_rates(s, h0, d0, ms, mu, ks, cs, a, kt, ct, k1)
        for i in range(4):
            tmp[i] = s[i] + 0.5 * dt * k1[i]
        _quarter_rates(tmp, hm, dm, ms, mu, ks, cs, a, kt, ct, k2)
        for i in range(4):
            tmp[i] = s[i] + 0.5 * dt * k2[i]
        _quarter_rates(tmp, hm, dm, ms, mu, ks, cs, a, kt, ct, k3)
        for i in range(4):
            tmp[i] = s[i] + dt * k3[i]
        _quarter_rates(tmp, h1, d1, ms, mu, ks, cs, a, kt, ct, k4)
        for i in range(4):
            s[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


#: What each record model adds to the fitted one, in words (records' ``problem.info``).
DESCRIPTIONS = {
    "bilinear_damper": (f"a bilinear damper, rebound {1 + DAMPER_ASYMMETRY:g}/compression "
                        f"{1 - DAMPER_ASYMMETRY:g} times cs (RK4); the fitted damper is linear"),
    "seat": (f"a driver and seat of {SEAT['mass_kg']:g} kg on a {SEAT['hz']:g} Hz cushion "
             f"{SEAT['x_m']:g} m ahead of the centre of gravity (a fifth degree of freedom "
             "the fitted half car lacks)"),
    "magic_formula": ("Magic Formula tyres (shape 1.4675, friction 0.94, curvature 0.004; "
                      "RK4); the fitted tyres are linear"),
}


#: The richer fitted structure the suite has for each record model (issue 43): what fits the
#: record's dynamics; ``None`` where the suite has none (the seat's fifth degree of freedom).
FIT_WITH = {
    "bilinear_damper": "problem.damper=bilinear (bump and rebound coefficients, "
                       "vpid_vehicle.ride.structures)",
    "seat": None,
    "magic_formula": "problem=lateral_mf (the Magic Formula single-track model)",
}


#: Columns of :func:`bilinear_quarter`'s full output, by sensor name.
QUARTER_CHANNELS = {"zs''": 0, "zu''": 1, "zs": 2, "zu": 3, "zs-zu": 4}


def bilinear_quarter(x: np.ndarray, kt: float, ct: float, u: np.ndarray, dt: float,
                     asymmetry: float = DAMPER_ASYMMETRY) -> np.ndarray:
    """The quarter car with the bilinear damper by RK4 at ``dt``: ``(N, 5)`` (QUARTER_CHANNELS)."""
    y = np.empty((u.shape[0], 5))
    _bilinear_rk4(np.ascontiguousarray(x, dtype=float), float(kt), float(ct),
                  float(asymmetry), np.ascontiguousarray(u, dtype=float), float(dt), y)
    return y
