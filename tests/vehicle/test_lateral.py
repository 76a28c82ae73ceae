"""The linear single-track model on the shared core: the steady-state yaw gain against the
understeer-gradient formula, the oversteering car's critical speed, the scaling symmetry that
makes the mass a necessary known, local identifiability with it, the manoeuvres."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_vehicle.ride import linear
from vpid_vehicle.ride.lateral import (
    LateralConfig,
    LateralProblem,
    SingleTrack,
    steady_yaw_gain,
)


def _set(name: str) -> tuple[np.ndarray, dict[str, float]]:
    s = SingleTrack.sets[name]
    return (np.array([[s[k] for k in SingleTrack.names]]),
            {k: v for k, v in s.items() if k not in SingleTrack.names})


@pytest.mark.parametrize("name, vx", [("civic", 20.0), ("civic", 35.0), ("smart", 20.0)])
def test_steady_state_yaw_gain_matches_the_understeer_formula(name, vx):
    """A held steer: after 10 s the yaw rate per steer angle equals vx / (L + K vx^2) to 1e-6
    (exact solution)."""
    X, known = _set(name)
    dt, N = 0.01, 1500
    u = np.full((N, 1), 0.01)
    y = linear.simulate(linear.exact_foh(SingleTrack().system(X, known, "yaw", vx), dt), u)[0]
    assert y[-1, 0] / 0.01 == pytest.approx(steady_yaw_gain(X, known, vx)[0], rel=1e-6)


def test_the_smart_oversteers_and_is_unstable_above_its_critical_speed():
    """K < 0: critical speed sqrt(-L / K) = 35.8 m/s; below it the model is stable, above it
    an eigenvalue of the state matrix has a positive real part."""
    X, known = _set("smart")
    Cf, Cr, _, lf = X[0]
    K = known["m"] / known["L"] * ((known["L"] - lf) / Cf - lf / Cr)
    v_crit = np.sqrt(-known["L"] / K)
    assert v_crit == pytest.approx(35.8, abs=0.1)
    for vx, stable in ((0.9 * v_crit, True), (1.1 * v_crit, False)):
        Ac = SingleTrack().system(X, known, "yaw", vx).continuous()[0][0]
        assert (np.max(np.linalg.eigvals(Ac).real) < 1e-9) == stable


def test_scaling_mass_inertia_and_cornering_stiffnesses_leaves_yaw_and_ay_unchanged():
    X, known = _set("civic")
    u = LateralProblem(LateralConfig(noise_level=0)).u
    model = SingleTrack()
    a = linear.simulate(linear.exact_foh(model.system(X, known, "yaw_ay"), 1e-3), u)[0]
    Xs = X * np.array([1.7, 1.7, 1.7, 1.0])
    ks = dict(known, m=1.7 * known["m"])
    b = linear.simulate(linear.exact_foh(model.system(Xs, ks, "yaw_ay"), 1e-3), u)[0]
    assert np.max(np.abs(a - b)) < 1e-9 * np.max(np.abs(a))


@pytest.mark.parametrize("manoeuvre", ["step", "sine"])
def test_with_the_mass_known_the_model_is_locally_identifiable(manoeuvre):
    p = LateralProblem(LateralConfig(noise_level=0.0, manoeuvre=manoeuvre))
    x = p.x_true
    cols = []
    for j in range(x.size):
        h = 1e-6 * x[j]
        up, dn = x.copy(), x.copy()
        up[j] += h
        dn[j] -= h
        cols.append((p.residuals(up[None])[0] - p.residuals(dn[None])[0]) / (2 * h) * x[j])
    s = np.linalg.svd(np.stack(cols, axis=1), compute_uv=False)
    assert s[-1] / s[0] > 1e-4, s


def test_the_manoeuvres_and_bad_values():
    from vpid_bench import ConfigError

    step = LateralProblem(LateralConfig(manoeuvre="step", steer_deg=2.0, noise_level=0))
    assert step.u[0, 0] == 0 and step.u[-1, 0] == pytest.approx(np.deg2rad(2.0))
    sine = LateralProblem(LateralConfig(manoeuvre="sine", noise_level=0))
    assert np.max(sine.u) == pytest.approx(np.deg2rad(2.0), rel=1e-3)
    with pytest.raises(ConfigError) as err:
        LateralConfig(steer_deg=30.0)
    assert err.value.key == "problem.steer_deg"


def test_magic_formula_model_tends_to_the_linear_one_at_small_steer():
    """At 0.05 degrees of steer the tyres stay in their linear range: the Magic Formula model
    with B C D equal to the linear set's cornering stiffnesses gives the linear model's yaw
    rate and lateral acceleration within 1e-3 of their peaks."""
    from vpid_vehicle.ride.magic import LateralMFConfig, LateralMFProblem

    mf = LateralMFProblem(LateralMFConfig(steer_deg=0.05, noise_level=0.0, truth="set"))
    lin = LateralProblem(LateralConfig(steer_deg=0.05, noise_level=0.0, truth="set"))
    y_mf = mf.responses(mf.x_true[None])[0]
    y_lin = lin.responses(lin.x_true[None])[0]
    for c in range(2):
        assert np.max(np.abs(y_mf[c] - y_lin[c])) < 1e-3 * np.max(np.abs(y_lin[c]))


def test_magic_formula_fit_converges_to_the_record():
    """The record (RK4 at dt / 10 on the finely sampled steer) against the fitted model (RK4 at
    dt = 4, 2, 1 ms, the steer linear between its samples): the error falls about 4x per
    halving (second order: the steer's interpolation, not RK4, limits it) and is below 1e-5
    of the peak at 1 ms, so the model error this record carries is small."""
    from vpid_vehicle.ride.magic import LateralMFConfig, LateralMFProblem

    p = LateralMFProblem(LateralMFConfig(noise_level=0.0, truth="set"))
    errors = []
    for dt in (0.004, 0.002, 0.001):
        u = p.model.inputs(p.config, p.known, dt / 10, np.random.default_rng(0))
        fine = p.model.simulate(p.x_true[None], p.known, "yaw_ay", u, dt / 10, "exact")[0]
        coarse = p.model.simulate(p.x_true[None], p.known, "yaw_ay", u[::10], dt,
                                  "newmark")[0]
        errors.append(np.max(np.abs(coarse - fine[::10])) / np.max(np.abs(fine)))
    assert 3 < errors[0] / errors[1] < 5 and 3 < errors[1] / errors[2] < 5
    assert errors[2] < 1e-5


def test_magic_formula_reaches_the_nonlinear_range_by_default():
    """At the default 4 degrees of sine steer the front tyre's force at its largest slip angle
    is more than 15 % below the linear tyre's (B C D a): the record carries the tyre's
    nonlinearity."""
    from vpid_vehicle.ride.magic import LateralMFConfig, LateralMFProblem

    p = LateralMFProblem(LateralMFConfig(noise_level=0.0, truth="set", sensors="yaw_ay_beta"))
    y = p.responses(p.x_true[None])[0]
    r, beta = y[0], y[2]
    vx = p.config.speed_kmh / 3.6
    alpha_f = p.u[:, 0] - beta - p.known["lf"] * r / vx
    a = np.max(np.abs(alpha_f))
    B, C, D = p.x_true[:3]
    force = D * np.sin(C * np.arctan(B * a - p.known["E"] * (B * a - np.arctan(B * a))))
    assert force / (B * C * D * a) < 0.85


def test_magic_formula_kernel_matches_an_independent_ode_solution():
    """The compiled RK4 kernel at 1 ms against scipy's DOP853 at rtol 1e-12 on the same
    equations (written here again from the Magic Formula and the single-track balance),
    solved sample interval by sample interval so that the steer is linear, hence smooth,
    within each solve: yaw rate, lateral acceleration and side slip agree within 1e-9 of
    their peaks (RK4's own error at this step is about 3e-11 of the peak: it falls 16x per
    halving), for two candidates in one batch, one of them far from the set."""
    from scipy.integrate import solve_ivp
    from vpid_vehicle.ride.magic import LateralMFConfig, LateralMFProblem

    p = LateralMFProblem(LateralMFConfig(noise_level=0.0, truth="set", duration_s=1.0,
                                         sensors="yaw_ay_beta"))
    X = np.vstack([p.x_true, p.x_true * np.array([1.3, 0.8, 1.2, 0.7, 1.1, 0.9, 1.4])])
    y = p.model.simulate(X, p.known, "yaw_ay_beta", p.u, p.config.dt, "newmark")
    m, lf, E, vx = p.known["m"], p.known["lf"], p.known["E"], p.config.speed_kmh / 3.6
    lr, t, steer = p.known["L"] - lf, np.arange(p.u.shape[0]) * p.config.dt, p.u[:, 0]

    def forces(x: np.ndarray, vy: float, r: float, delta: float) -> tuple[float, float]:
        def tyre(a: float, B: float, C: float, D: float) -> float:
            return D * np.sin(C * np.arctan(B * a - E * (B * a - np.arctan(B * a))))
        return (tyre(delta - (vy + lf * r) / vx, *x[:3]),
                tyre(-(vy - lr * r) / vx, *x[3:6]))

    for x, got in zip(X, y):
        states = [np.zeros(2)]
        for k in range(len(t) - 1):
            def rhs(time: float, s: np.ndarray, k: int = k, x: np.ndarray = x) -> list[float]:
                w = (time - t[k]) / (t[k + 1] - t[k])
                ff, fr = forces(x, s[0], s[1], (1 - w) * steer[k] + w * steer[k + 1])
                return [(ff + fr) / m - vx * s[1], (lf * ff - lr * fr) / x[6]]

            sol = solve_ivp(rhs, (t[k], t[k + 1]), states[-1], method="DOP853", rtol=1e-12,
                            atol=1e-15)
            states.append(sol.y[:, -1])
        vy, r = np.array(states).T
        ay = [sum(forces(x, a, b, d)) / m for a, b, d in zip(vy, r, steer)]
        for c, want in enumerate((r, np.array(ay), vy / vx)):
            assert np.max(np.abs(got[:, c] - want)) < 1e-9 * np.max(np.abs(want))
