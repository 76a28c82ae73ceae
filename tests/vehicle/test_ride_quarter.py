"""The ride suite's quarter car and its simulation core, against independent solutions:
Newmark against the exact solution (second order in dt), the golden car's undamped modes
against hand computation, the ISO 8608 road's PSD against its formula, the scaling symmetry
that makes the known tyre necessary, local identifiability with it, and the instances (a
random truth, never the box centre)."""

from __future__ import annotations

import zlib

import numpy as np
import pytest
from scipy.integrate import trapezoid
from scipy.signal import welch
from vpid_vehicle.ride import linear, roads
from vpid_vehicle.ride.quarter import (
    QuarterCar,
    RideQuarterConfig,
    RideQuarterProblem,
    quarter_system,
)

GOLDEN = QuarterCar.sets["golden_car"]
X_GOLDEN = np.array([[GOLDEN[k] for k in QuarterCar.names]])


def _sdof(m: float, c: float, k: float) -> linear.LinearSystem:
    """A base-excited single mass: m q'' + c q' + k q = k u (output q'')."""
    return linear.LinearSystem(np.array([[[m]]]), np.array([[[c]]]), np.array([[[k]]]),
                               np.array([[[k]]]), np.array([[1.0]]), np.array([[0.0]]),
                               np.array([[0.0]]))


def test_exact_solution_against_the_closed_form_step_response():
    """An undamped mass on a spring after a unit step of its base: q = 1 - cos(w t), so
    q'' = w^2 cos(w t); the first-order-hold solution with a sampled step matches to 1e-9."""
    m, k = 2.0, 800.0
    w = np.sqrt(k / m)
    dt, N = 1e-3, 2000
    u = np.ones((N, 1))
    y = linear.simulate(linear.exact_foh(_sdof(m, 0.0, k), dt), u)[0, :, 0]
    t = np.arange(N) * dt
    assert np.max(np.abs(y - w**2 * np.cos(w * t))) < 1e-9 * w**2


def test_newmark_converges_to_the_exact_solution_at_second_order():
    """The quarter car over a hump: Newmark's error against the exact solution falls about 4x
    when dt halves (second order), and is below 1 % of the peak at dt = 0.5 ms."""
    cfg = RideQuarterConfig(dt=0.001)
    errors = []
    for dt in (0.002, 0.001, 0.0005):
        u = np.stack([roads.hump(np.arange(round(2.0 / dt)) * dt * 30 / 3.6, 1.0),
                      np.zeros(round(2.0 / dt))], axis=1)
        system = quarter_system(X_GOLDEN, GOLDEN["kt"], GOLDEN["ct"], cfg.sensors)
        exact = linear.simulate(linear.exact_foh(system, dt), u)[0]
        approx = linear.simulate(linear.newmark(system, dt), u)[0]
        errors.append(np.max(np.abs(approx - exact)) / np.max(np.abs(exact)))
    assert 3.0 < errors[0] / errors[1] < 5.0 and 3.0 < errors[1] / errors[2] < 5.0
    assert errors[2] < 0.01


def test_golden_car_undamped_modes_match_hand_computation():
    """Body 1.208 Hz and wheel hop 11.005 Hz (eig(K, M) of the golden car's ratios)."""
    s = quarter_system(X_GOLDEN, GOLDEN["kt"], 0.0, "body")
    f = linear.undamped_frequencies_hz(s.M[0], s.K[0])
    assert f == pytest.approx([1.208, 11.005], abs=1e-3)


@pytest.mark.parametrize("road_class", ["A", "E"])
def test_iso8608_road_psd_matches_its_formula(road_class):
    """Welch's one-sided PSD of a 1 km road (500 sinusoids), integrated over octave bands of
    0.02-2.56 cycles/m, within 15 % of the integral of Gd(n) (the tolerance covers Welch's
    leakage and variance at this length)."""
    dx = roads.ISO8608_DX * 5
    x = np.arange(0, 1000.0, dx)
    h = roads.iso8608(x, road_class, np.random.default_rng(1), waves=500, taper_m=0.0)
    n, psd = welch(h, fs=1 / dx, nperseg=2**13)
    for lo in (0.02, 0.04, 0.08, 0.16, 0.32, 0.64, 1.28):
        band = (n >= lo) & (n < 2 * lo)
        measured = trapezoid(psd[band], n[band])
        expected = trapezoid(roads.iso8608_psd(n[band], road_class), n[band])
        assert measured == pytest.approx(expected, rel=0.15), (road_class, lo)


def test_iso8608_class_means_are_the_standard_geometric_means():
    assert roads.ISO8608_GD0["A"] == pytest.approx(16e-6)
    assert roads.ISO8608_GD0["C"] == pytest.approx(256e-6)
    assert roads.ISO8608_GD0["H"] == pytest.approx(262144e-6)


def _record(X: np.ndarray, kt: float) -> np.ndarray:
    u = np.stack([roads.hump(np.arange(3000) * 1e-3 * 30 / 3.6, 1.0), np.zeros(3000)], axis=1)
    return linear.simulate(linear.exact_foh(quarter_system(X, kt, 0.0, "body_wheel_stroke"),
                                            1e-3), u)[0]


def test_scaling_every_parameter_and_the_tyre_leaves_the_record_unchanged():
    """The structural symmetry: masses, stiffnesses, dampings and kt all x 1.7 give the same
    accelerations and stroke (so one quantity must be known: the tyre)."""
    a = _record(X_GOLDEN, GOLDEN["kt"])
    b = _record(1.7 * X_GOLDEN, 1.7 * GOLDEN["kt"])
    assert np.max(np.abs(a - b)) < 1e-9 * np.max(np.abs(a))


def _scaled_jacobian(problem: RideQuarterProblem, x: np.ndarray) -> np.ndarray:
    """d residuals / d log(parameter), central differences (relative step 1e-6)."""
    cols = []
    for j in range(x.size):
        h = 1e-6 * x[j]
        up, dn = x.copy(), x.copy()
        up[j] += h
        dn[j] -= h
        cols.append((problem.residuals(up[None])[0] - problem.residuals(dn[None])[0])
                    / (2 * h) * x[j])
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("sensors", ["body", "body_wheel"])
def test_with_the_tyre_known_the_quarter_car_is_locally_identifiable(sensors):
    """The scaled Jacobian's smallest/largest singular value ratio is far from zero (1e-3 and
    above, against < 1e-6 for an unidentifiable direction)."""
    p = RideQuarterProblem(RideQuarterConfig(sensors=sensors, noise_level=0.0))
    s = np.linalg.svd(_scaled_jacobian(p, p.x_true), compute_uv=False)
    assert s[-1] / s[0] > 1e-3


def test_instances_draw_a_random_truth_inside_the_box_never_the_centre():
    cfg = RideQuarterConfig()
    p = RideQuarterProblem(cfg)
    truths = np.array([p.instance(i).x_true for i in range(20)])
    lo, hi = p.bounds.lower, p.bounds.upper
    margin = cfg.truth_margin * (hi - lo)
    assert np.all((truths >= lo + margin) & (truths <= hi - margin))
    centre = (lo + hi) / 2
    assert np.min(np.linalg.norm(truths / centre - 1, axis=1)) > 0.01
    assert len({p.instance(i).instance_id() for i in range(20)}) == 20
    # the same index gives the same instance (paired runs across optimizers)
    assert np.array_equal(p.instance(3).measured, RideQuarterProblem(cfg, 3).measured)
    # truth=set: the published set, at the box centre
    q = RideQuarterProblem(RideQuarterConfig(truth="set"))
    assert np.allclose(q.x_true, (q.bounds.lower + q.bounds.upper) / 2)


def test_random_truths_cover_the_whole_box_but_its_margin():
    """draw_truth is uniform over the box less truth_margin of its width at each side: over
    4000 draws each coordinate passes a Kolmogorov-Smirnov test against that uniform law
    (p > 0.001) and comes within 1 % of the width of both ends; a third of the draws lie
    outside the central 60 % of the box, where every truth lay before round four."""
    from scipy import stats
    from vpid_vehicle.ride.problem import TRUTH_MARGIN, draw_truth

    lower, upper = np.array([1.0, -2.0, 10.0]), np.array([3.0, 5.0, 10.5])
    rng = np.random.default_rng(5)
    X = np.array([draw_truth(lower, upper, TRUTH_MARGIN, rng) for _ in range(4000)])
    u = (X - lower) / (upper - lower)
    for j in range(3):
        assert stats.kstest(u[:, j], stats.uniform(TRUTH_MARGIN, 1 - 2 * TRUTH_MARGIN).cdf
                            ).pvalue > 1e-3
        assert u[:, j].min() < TRUTH_MARGIN + 0.01 and u[:, j].max() > 1 - TRUTH_MARGIN - 0.01
    outside = np.mean((u < 0.2) | (u > 0.8))
    assert outside == pytest.approx(0.3 / 0.9, abs=0.03)
    # the problem's truth is this draw from the instance's truth stream
    p = RideQuarterProblem(RideQuarterConfig(), 2)
    from vpid_vehicle.ride.problem import instance_streams

    rng = np.random.default_rng(instance_streams(0, 2, "ride_quarter")[0])
    np.testing.assert_allclose(p.x_true, draw_truth(p.bounds.lower, p.bounds.upper,
                                                    TRUTH_MARGIN, rng))


def test_noise_is_additive_with_the_stated_sigma_per_channel():
    p = RideQuarterProblem(RideQuarterConfig(noise_level=0.05, duration_s=20.0,
                                             road="iso8608"))
    rms = np.sqrt(np.mean(p.clean**2, axis=1))
    resid = p.measured - p.clean
    assert np.std(resid, axis=1) == pytest.approx(0.05 * rms, rel=0.05)
    # in the units of the Fisher residuals (over ||measured_c||), per channel
    np.testing.assert_allclose(p.residual_sigma(), p.sigma / p.scale, rtol=1e-12)
    assert np.array_equal(p.fisher_groups(), np.repeat(np.arange(p.measured.shape[0]),
                                                       p.t.size))


def test_the_record_is_not_made_by_the_fitted_model():
    """Noise-free, the truth does not fit exactly with record=exact (model error, small) and
    fits to rounding with record=newmark (the inverse crime, kept as an option)."""
    exact = RideQuarterProblem(RideQuarterConfig(noise_level=0.0))
    crime = RideQuarterProblem(RideQuarterConfig(noise_level=0.0, record="newmark"))
    f_exact = exact.evaluate(exact.x_true[None])[0]
    f_crime = crime.evaluate(crime.x_true[None])[0]
    assert 1e-6 < f_exact < 0.05
    assert f_crime < 1e-10


def test_the_step_edge_is_rounded_so_a_tyre_damped_record_stays_fittable():
    """The step rises monotonically to its height over 0.15 m (half a raised cosine). With
    the quarter bus's tyre damping a sharp step would make the wheel acceleration a Dirac
    pulse whose sampled value depends on the record's step (the noise-free truth then misfit
    by over 100 %); with the rounded edge the noise-free truth fits within 1 %."""
    x = np.linspace(-1.0, 1.0, 2001)
    h = roads.step(x, 0.0)
    assert h[0] == 0 and h[-1] == pytest.approx(0.10) and np.all(np.diff(h) >= 0)
    assert np.all(h[x >= 0.15] == pytest.approx(0.10)) and np.all(h[x <= 0] == 0)
    bus = RideQuarterProblem(RideQuarterConfig(parameter_set="quarter_bus", road="step",
                                               sensors="body_wheel_stroke", noise_level=0.0))
    assert bus.evaluate(bus.x_true[None])[0] < 0.01


def test_bad_settings_are_refused_naming_the_key():
    from vpid_bench import ConfigError

    with pytest.raises(ConfigError) as err:
        RideQuarterConfig(truth_margin=0.6)
    assert err.value.key == "problem.truth_margin"
    with pytest.raises(ConfigError) as err:
        RideQuarterConfig(duration_s=60.0, dt=1e-4)
    assert err.value.key == "problem.duration_s"
    with pytest.raises(ConfigError) as err:
        RideQuarterConfig(road="pothole")
    assert err.value.key == "problem.road" and "iso8608" in str(err.value)


def test_the_instances_streams_are_not_the_optimizers():
    """At equal seeds, instance i's streams (truth, road, noise) share no state with the
    optimizer's stream of run i (SeedSequence(seed, spawn_key=(i,))): their first draws
    differ, and instance i is reproduced from its documented root."""
    from vpid_vehicle.ride.problem import instance_streams

    from vpid_bench.build import run_rng

    for i in range(3):
        optimizer = run_rng(0, i).random(8)
        for stream in instance_streams(0, i, "ride_quarter"):
            assert not np.allclose(np.random.default_rng(stream).random(8), optimizer)
    p = RideQuarterProblem(RideQuarterConfig(), 2)
    root = np.random.SeedSequence([0, 0x5EED1, zlib.crc32(b"ride_quarter")], spawn_key=(2,))
    truth_rng = np.random.default_rng(root.spawn(3)[0])
    u = truth_rng.uniform(0.05, 0.95, 4)
    np.testing.assert_allclose(p.x_true, p.bounds.lower + u * p.bounds.width)
