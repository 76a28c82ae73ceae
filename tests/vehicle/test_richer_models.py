"""The richer models that make the model-error members' records (vpid_vehicle/ride/richer.py)
against independent solutions, the model error stated against the noise, and the one import
direction between the single-track modules."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vpid_vehicle.ride import linear
from vpid_vehicle.ride.half import HalfCar
from vpid_vehicle.ride.quarter import quarter_system
from vpid_vehicle.ride.richer import SEAT, bilinear_quarter, seated_half

X_Q = np.array([250.0, 37.5, 15825.0, 1500.0])  # golden car corner
KT, CT = 163250.0, 0.0
DT = 1e-4


def hump(t):
    """A smooth hump, 0.1 m over 0.4 s from 0.1 s on: its height (m) and rate (m/s) at
    ``t`` (s), exactly (the independent solutions use this; the records its samples, linear
    between them: a difference of 2e-8 m)."""
    t = np.asarray(t, dtype=float)
    inside = (t > 0.1) & (t < 0.5)
    phase = 2 * np.pi * (t - 0.1) / 0.4
    return (np.where(inside, 0.05 * (1 - np.cos(phase)), 0.0),
            np.where(inside, 0.05 * np.sin(phase) * 2 * np.pi / 0.4, 0.0))


def _road(n=8000):
    """The hump and its rate sampled every DT, ``(t, u)`` with ``u`` ``(n, 2)``."""
    t = np.arange(n) * DT
    return t, np.stack(hump(t), axis=1)


def test_the_bilinear_damper_without_asymmetry_is_the_linear_quarter_car():
    """a = 0: RK4 at 0.1 ms against the exact first-order-hold solution of the linear car,
    within 1e-6 of the signal's peak."""
    t, u = _road()
    y = bilinear_quarter(X_Q, KT, CT, u, DT, asymmetry=0.0)
    exact = linear.simulate(linear.exact_foh(quarter_system(X_Q[None], KT, CT,
                                                           "body_wheel_stroke"), DT), u)[0]
    for j, col in enumerate((0, 1, 4)):
        scale = np.abs(exact[:, j]).max()
        np.testing.assert_allclose(y[:, col], exact[:, j], rtol=0, atol=1e-6 * scale)


def test_the_bilinear_damper_against_an_independent_integrator():
    """a = 0.5: the same equations written again and solved by scipy's DOP853 (rtol 1e-11)
    with the road linear between samples: the body acceleration agrees within 1e-5 of its
    peak (RK4 loses an order where the damper switches)."""
    t, u = _road()
    a = 0.5
    ms, mu, ks, cs = X_Q

    def rhs(s_, s):
        h, hd = hump(s_)
        v = s[2] - s[3]
        damper = cs * (1 + a) * v if v > 0 else cs * (1 - a) * v
        spring = ks * (s[0] - s[1])
        return [s[2], s[3], -(spring + damper) / ms,
                (spring + damper - KT * (s[1] - h) - CT * (s[3] - hd)) / mu]

    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(4), method="DOP853", t_eval=t[::50],
                    rtol=1e-11, atol=1e-13, max_step=0.01)
    zs_dd = np.array([rhs(s_, s)[2] for s_, s in zip(sol.t, sol.y.T, strict=True)])
    y = bilinear_quarter(X_Q, KT, CT, u, DT, asymmetry=a)
    scale = np.abs(zs_dd).max()
    np.testing.assert_allclose(y[::50, 0], zs_dd, rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(y[::50, 4], sol.y[0] - sol.y[1], rtol=0,
                               atol=1e-5 * np.abs(sol.y[0] - sol.y[1]).max())
    # and the asymmetry matters: the response differs from the linear car's by > 5 %
    lin = bilinear_quarter(X_Q, KT, CT, u, DT, asymmetry=0.0)
    assert np.abs(y[:, 0] - lin[:, 0]).max() > 0.05 * scale


def test_the_seated_half_car_against_its_equations_written_by_hand():
    """The seat's fifth degree of freedom written as forces on the body (the cushion's
    elongation e = zs - x + s theta pushes x by +k e + c e', theta by -s (k e + c e'), the
    seat by -(k e + c e')) over the 4-DOF half car, solved by scipy's DOP853: the body
    accelerations agree with seated_half's exact solution within 1e-6 of their peak."""
    known = {"L": 2.566, "kt1": 155900.0, "kt2": 155900.0}
    x = np.array([505.1, 651.0, 28.58, 54.3, 15000.0, 15000.0, 1828.0, 1828.0, 1.468])
    half = HalfCar().system(x[None], known, "body")
    t = np.arange(8000) * DT
    delay = 0.3  # s: the rear wheel meets the hump this much later
    (h1, r1), (h2, r2) = hump(t), hump(t - delay)
    u = np.stack([h1, h2, r1, r2], axis=1)
    seated = seated_half(half)
    y = linear.simulate(linear.exact_foh(seated, DT), u)[0]

    M, C, K, F = half.M[0], half.C[0], half.K[0], half.F[0]
    m, s = SEAT["mass_kg"], SEAT["x_m"]
    w = 2 * np.pi * SEAT["hz"]
    k, c = m * w**2, 2 * SEAT["zeta"] * m * w
    Minv = np.linalg.inv(M)

    def acc(s_, st):
        q, v, zs, vs = st[:4], st[4:8], st[8], st[9]
        e, ed = zs - q[0] + s * q[1], vs - v[0] + s * v[1]
        force = k * e + c * ed
        gen = np.array([force, -s * force, 0.0, 0.0])
        (a1, b1), (a2, b2) = hump(s_), hump(s_ - delay)
        a = Minv @ (F @ np.array([a1, a2, b1, b2]) - C @ v - K @ q + gen)
        return a, -force / m

    def rhs(s_, st):
        a, azs = acc(s_, st)
        return np.concatenate([st[4:8], a, [st[9], azs]])

    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(10), method="DOP853", t_eval=t[::20],
                    rtol=1e-11, atol=1e-13, max_step=0.01)
    a1 = np.array([acc(s_, st)[0] for s_, st in zip(sol.t, sol.y.T, strict=True)])
    a1_l = x[8]
    z1 = a1[:, 0] - a1_l * a1[:, 1]
    z2 = a1[:, 0] + (known["L"] - a1_l) * a1[:, 1]
    for j, ref in enumerate((z1, z2)):
        np.testing.assert_allclose(y[::20, j], ref, rtol=0, atol=1e-6 * np.abs(ref).max())


def test_a_member_without_model_error_has_a_ratio_far_below_one():
    from vpid_vehicle.ride.model_error import model_error
    from vpid_vehicle.ride.suites import MEMBERS

    cls = {m.name: m for m in MEMBERS}["vpid1_q_golden_hump"]
    assert model_error(cls(cls.Config()))["ratio"] < 1e-2


@pytest.mark.parametrize("name", ["vpid1_q_golden_bilinear", "vpid1_h_gokdag_seat_iso_c"])
def test_model_error_members_say_so_in_their_records(name):
    from vpid_vehicle.ride.suites import MEMBERS

    cls = {m.name: m for m in MEMBERS}[name]
    info = cls(cls.Config()).describe()
    assert info["model_error"]["record_model"] in ("bilinear_damper", "seat")
    assert "fitted" in info["model_error"]["what"]


def test_magic_never_imports_lateral():
    """ride/lateral.py uses ride/magic.py (its model-error record); magic imports neither
    lateral nor anything that imports it: one direction."""
    root = Path(__file__).resolve().parents[2] / "plugins" / "vpid_vehicle" / "ride"
    for name in ("magic.py", "steering.py"):
        tree = ast.parse((root / name).read_text())
        imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
        assert "lateral" not in imported, name
