"""The ride models' richer suspension structures (:mod:`vpid_vehicle.ride.structures`):
nested with the linear model, their elements where the linear matrices put them, their RK4
against independent solutions, and their keys refused with the allowed values."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_vehicle.ride import structures
from vpid_vehicle.ride.full import RideFullProblem
from vpid_vehicle.ride.half import RideHalfProblem
from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem

from vpid_bench import ConfigError

FAMILIES = (RideQuarterProblem, RideHalfProblem, RideFullProblem)


def _nested(structured: structures.StructuredModel, x_linear: np.ndarray) -> np.ndarray:
    """The structured row equal to the linear row ``x_linear``: no cubic term, bump =
    rebound."""
    col = dict(zip(structured.base.names, x_linear, strict=True))
    out = []
    for name in structured.names:
        stem, _, kind = name.rpartition("_")
        out.append(0.0 if kind == "cubic" else col[stem] if kind in ("bump", "rebound")
                   else col[name])
    return np.array(out)


@pytest.mark.parametrize("family", FAMILIES)
def test_the_richest_structure_holds_the_linear_one(family):
    """With no cubic term and bump = rebound, the RK4 of the structure reproduces the linear
    model's exact solution (first-order hold) to 1e-5 of the channel's rms."""
    lin = family(family.Config(duration_s=1.0))
    rich = family(family.Config(duration_s=1.0, spring="cubic", damper="bilinear"))
    x = _nested(rich.model, lin.x_true)
    lo, hi = rich.bounds.lower, rich.bounds.upper
    assert np.all((x >= lo) & (x <= hi)), "the linear structure lies inside the richer box"
    y_rich = rich.model.simulate(x[None], lin.known, lin.config.sensors, lin.u, lin.config.dt,
                                 "newmark")
    y_lin = lin.model.simulate(lin.x_true[None], lin.known, lin.config.sensors, lin.u,
                               lin.config.dt, "exact")
    rms = np.sqrt(np.mean(y_lin**2, axis=1))
    assert np.max(np.abs(y_rich - y_lin) / rms) < 1e-5


@pytest.mark.parametrize("family", FAMILIES)
def test_the_elements_are_where_the_linear_stiffness_puts_them(family):
    """Each axle's springs are ``sum J_e^T J_e`` of its elements in the linear ``K``: the
    derivative of ``K`` in the axle's linear rate (exact: K is linear in it)."""
    p = family(family.Config(duration_s=0.5))
    base = p.model
    susp = type(base).suspension
    x = p.x_true
    J = susp.elongations(x[None], p.known)[0]
    for a, (k, _) in enumerate(susp.axles):
        dx = x.copy()
        dx[base.names.index(k)] += 1.0
        dK = (base.system(dx[None], p.known, p.config.sensors).K
              - base.system(x[None], p.known, p.config.sensors).K)[0]
        want = sum(np.outer(J[e], J[e]) for e in range(J.shape[0]) if susp.axle_of[e] == a)
        np.testing.assert_allclose(dK, want, atol=1e-9)


def test_the_bilinear_damper_matches_the_suites_record_model():
    """``damper=bilinear`` with bump ``0.5 cs`` and rebound ``1.5 cs`` is the record model of
    ``vpid1_q_golden_bilinear`` (:func:`.richer.bilinear_quarter`, RK4 written apart)."""
    from vpid_vehicle.ride.richer import QUARTER_CHANNELS, bilinear_quarter

    p = RideQuarterProblem(RideQuarterConfig(duration_s=1.0, damper="bilinear",
                                             sensors="body_wheel_stroke"))
    ms, mu, ks, cs = 250.0, 37.5, 15825.0, 1500.0
    x = np.array([ms, mu, ks, 0.5 * cs, 1.5 * cs])
    got = p.model.simulate(x[None], p.known, p.config.sensors, p.u, p.config.dt, "newmark")[0]
    want = bilinear_quarter(np.array([ms, mu, ks, cs]), p.known["kt"], p.known["ct"], p.u,
                            p.config.dt)[:, [QUARTER_CHANNELS[c] for c, _ in p.channels]]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())


def test_the_cubic_spring_matches_an_adaptive_ode_solution():
    """The quarter car with a cubic spring against scipy's adaptive RK45 at tight tolerances
    (the road linear between samples): the body acceleration within 1e-4 of its peak."""
    from scipy.integrate import solve_ivp

    p = RideQuarterProblem(RideQuarterConfig(duration_s=1.0, spring="cubic", sensors="body"))
    ms, mu, ks, k3, cs = 250.0, 37.5, 15825.0, 2.0e6, 1500.0
    kt, ct = p.known["kt"], p.known["ct"]
    t = np.arange(p.u.shape[0]) * p.config.dt

    def rates(tt, s):
        h, hd = np.interp(tt, t, p.u[:, 0]), np.interp(tt, t, p.u[:, 1])
        e, ed = s[0] - s[1], s[2] - s[3]
        f = ks * e + k3 * e**3 + cs * ed
        return [s[2], s[3], -f / ms, (f - kt * (s[1] - h) - ct * (s[3] - hd)) / mu]

    sol = solve_ivp(rates, (0, t[-1]), np.zeros(4), t_eval=t, rtol=1e-10, atol=1e-12,
                    max_step=p.config.dt)
    zs, zu, vs, vu = sol.y
    e = zs - zu
    want = -(ks * e + k3 * e**3 + cs * (vs - vu)) / ms
    got = p.model.simulate(np.array([[ms, mu, ks, k3, cs]]), p.known, "body", p.u,
                           p.config.dt, "newmark")[0, :, 0]
    assert np.max(np.abs(got - want)) < 1e-4 * np.max(np.abs(want))


def test_the_parameters_are_named_with_units_and_boxes():
    p = RideQuarterProblem(RideQuarterConfig(duration_s=0.5, spring="cubic",
                                             damper="bilinear"))
    b = p.bounds
    assert b.names == ("ms", "mu", "ks", "ks_cubic", "cs_bump", "cs_rebound")
    assert b.units == ("kg", "kg", "N/m", "N/m³", "N s/m", "N s/m")
    cs, ks = 1500.0, 15825.0
    np.testing.assert_allclose(b.lower[3:], [0.0, 0.25 * cs, 0.5 * cs])
    np.testing.assert_allclose(b.upper[3:], [2 * structures.CUBIC_PER_K * ks, 1.5 * cs, 3.0 * cs])
    assert np.all((p.x_true > b.lower) & (p.x_true < b.upper))
    # the cubic term is 25 % of the linear spring's force at 50 mm of travel
    assert structures.CUBIC_PER_K * 0.05**2 == pytest.approx(0.25)


def test_the_linear_structure_keeps_the_models_own_kernel():
    p = RideQuarterProblem(RideQuarterConfig(duration_s=0.5))
    assert p.model is RideQuarterProblem.model


@pytest.mark.parametrize("key, value, allowed", [
    ("spring", "quintic", "linear, cubic"), ("damper", "soft", "linear, bilinear")])
def test_a_bad_structure_is_refused_naming_the_allowed_ones(key, value, allowed):
    with pytest.raises(ConfigError) as err:
        RideQuarterConfig(**{key: value})
    assert err.value.key == f"problem.{key}" and allowed in str(err.value)


def test_a_richer_structure_refuses_another_record_model():
    with pytest.raises(ConfigError) as err:
        RideQuarterConfig(damper="bilinear", record_model="bilinear_damper")
    assert err.value.key == "problem.record_model"
