"""The half and full car of the suite on the shared core, against independent solutions: the
symmetric full car (its own Jacobian derivation) equal to the half car of Eq. (2) with
per-axle values on identical tracks; the asymmetric one rolling; Newmark converging to the
exact solution for every model; local identifiability with the declared known quantities."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_vehicle.ride import linear
from vpid_vehicle.ride.full import FullCar, RideFullConfig, RideFullProblem, full_car_matrices
from vpid_vehicle.ride.half import HalfCar, RideHalfConfig, RideHalfProblem
from vpid_vehicle.ride.model import wheel_inputs
from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem

SYM = FullCar.sets["jazar_symmetric"]


def _full_record(parameter_set: str, sensors: str, dt: float = 1e-3) -> np.ndarray:
    full = FullCar()
    s = full.sets[parameter_set]
    known = {k: v for k, v in s.items() if k not in full.names}
    cfg = RideFullConfig(parameter_set=parameter_set, road="hump")
    u = wheel_inputs(cfg, full.wheels(known, cfg.speed_kmh / 3.6), dt, np.random.default_rng(0))
    X = np.array([[s[k] for k in full.names]])
    return linear.simulate(linear.exact_foh(full.system(X, known, sensors), dt), u)[0]


def test_symmetric_full_car_equals_the_half_car_with_per_axle_values():
    """bFL'' and bRL'' of the symmetric full car on identical tracks equal z1'' and z2'' of
    the half car (M, C, K of Eq. 2) with m, Iy, 2 mf, 2 mr, 2 kf, 2 kr, 2 cf, 2 cr, 2 kt,
    to 1e-9 of the peak."""
    full = _full_record("jazar_symmetric", "body")
    half = HalfCar()
    known = {"L": SYM["a1"] + SYM["a2"], "kt1": 2 * SYM["kt"], "kt2": 2 * SYM["kt"]}
    X = np.array([[SYM["m"], SYM["Iy"], 2 * SYM["mf"], 2 * SYM["mr"], 2 * SYM["kf"],
                   2 * SYM["kr"], 2 * SYM["cf"], 2 * SYM["cr"], SYM["a1"]]])
    cfg = RideHalfConfig(road="hump")
    u = wheel_inputs(cfg, half.wheels(known, cfg.speed_kmh / 3.6), 1e-3,
                     np.random.default_rng(0))
    z = linear.simulate(linear.exact_foh(half.system(X, known, "body"), 1e-3), u)[0]
    peak = np.max(np.abs(z))
    assert np.max(np.abs(full[:, 0] - z[:, 0])) < 1e-9 * peak  # front left = front
    assert np.max(np.abs(full[:, 2] - z[:, 1])) < 1e-9 * peak  # rear left = rear
    assert np.max(np.abs(full[:, 0] - full[:, 1])) < 1e-9 * peak  # left = right


def test_the_asymmetric_full_car_rolls_on_identical_tracks():
    """Jazar's yL = 0.70, yR = 0.75 m: the centre of gravity is off the centre line, so an
    identical left and right hump still rolls the body (the symmetric variant does not)."""
    roll = _full_record("jazar", "body_rates")[:, 4]
    still = _full_record("jazar_symmetric", "body_rates")[:, 4]
    assert np.max(np.abs(roll)) > 1e-4
    assert np.max(np.abs(still)) < 1e-12


def test_full_car_pitch_mode_matches_hand_computation():
    """Jazar's car: undamped pitch about 1.46 Hz (sqrt of the pitch stiffness over Iy with
    the tyres in series), the modes of a 7-DOF system, all distinct and positive."""
    full = FullCar()
    s = full.sets["jazar"]
    known = {k: v for k, v in s.items() if k not in full.names}
    M, _, K, _ = full_car_matrices(np.array([[s[k] for k in full.names]]), known)
    f = linear.undamped_frequencies_hz(M[0], K[0])
    kf = s["kf"] * s["kt"] / (s["kf"] + s["kt"])  # suspension and tyre in series
    kr = s["kr"] * s["kt"] / (s["kr"] + s["kt"])
    pitch = np.sqrt(2 * (kf * s["a1"] ** 2 + kr * s["a2"] ** 2) / s["Iy"]) / (2 * np.pi)
    assert np.min(np.abs(f[:3] - pitch)) < 0.05 * pitch
    assert f.size == 7 and np.all(np.diff(f) > 0) and f[0] > 0


@pytest.mark.parametrize("problem_cls, config", [
    (RideQuarterProblem, RideQuarterConfig()),
    (RideHalfProblem, RideHalfConfig()),
    (RideFullProblem, RideFullConfig()),
])
def test_newmark_converges_to_the_exact_solution_for_every_model(problem_cls, config):
    p = problem_cls(config)
    system = p.model.system(p.nominal[None], p.known, config.sensors)
    errors = []
    for dt in (0.002, 0.001, 0.0005):
        u = wheel_inputs(config, p.model.wheels(p.known, config.speed_kmh / 3.6), dt,
                         np.random.default_rng(0))
        exact = linear.simulate(linear.exact_foh(system, dt), u)[0]
        approx = linear.simulate(linear.newmark(system, dt), u)[0]
        errors.append(np.max(np.abs(approx - exact)) / np.max(np.abs(exact)))
    assert 3.0 < errors[0] / errors[1] < 5.0 and 3.0 < errors[1] / errors[2] < 5.0


def _scaled_jacobian(problem, x: np.ndarray) -> np.ndarray:
    cols = []
    for j in range(x.size):
        h = 1e-6 * x[j]
        up, dn = x.copy(), x.copy()
        up[j] += h
        dn[j] -= h
        cols.append((problem.residuals(up[None])[0] - problem.residuals(dn[None])[0])
                    / (2 * h) * x[j])
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("problem_cls, config", [
    (RideHalfProblem, RideHalfConfig(noise_level=0.0)),
    (RideFullProblem, RideFullConfig(noise_level=0.0)),
])
def test_with_the_declared_knowns_the_model_is_locally_identifiable(problem_cls, config):
    p = problem_cls(config)
    s = np.linalg.svd(_scaled_jacobian(p, p.x_true), compute_uv=False)
    assert s[-1] / s[0] > 1e-4, s


def test_the_commonroad_bmw_modes_match_hand_computation():
    """CommonRoad's BMW 320i set: the body modes near the front corner's bounce frequency,
    sqrt(kf kt / (kf + kt) / m_corner) / 2 pi with m_corner = m a2 / (a1 + a2) / 2 (1.419 Hz),
    within 2 %; the wheel hops at sqrt((kf + kt) / mf) / 2 pi (12.05 Hz) within 2 %."""
    from vpid_vehicle.ride.full import FullCar, RideFullConfig, RideFullProblem

    s = FullCar.sets["bmw320i"]
    p = RideFullProblem(RideFullConfig(parameter_set="bmw320i"))
    system = p.model.system(p.nominal[None], p.known, "body")
    f = linear.undamped_frequencies_hz(system.M[0], system.K[0])
    corner = s["m"] * s["a2"] / (s["a1"] + s["a2"]) / 2
    bounce = np.sqrt(s["kf"] * s["kt"] / (s["kf"] + s["kt"]) / corner) / (2 * np.pi)
    hop = np.sqrt((s["kf"] + s["kt"]) / s["mf"]) / (2 * np.pi)
    assert f[0] == pytest.approx(bounce, rel=0.02)
    assert np.all(np.abs(f[3:] / hop - 1) < 0.02)


def test_a_symmetric_car_on_identical_tracks_cannot_show_its_roll_inertia():
    """The BMW (centre of gravity on the centre line, no anti-roll bar) over a hump met by
    both tracks alike never rolls: Ix is structurally non-identifiable (a singular value at
    numerical zero, its direction on Ix); on an ISO road (independent tracks) every bound is
    under 1 %."""
    from vpid_vehicle.ride.full import RideFullConfig, RideFullProblem

    from vpid_bench.analysis.identifiability import cramer_rao
    from vpid_bench.analysis.profile import structural_symmetry

    hump = RideFullProblem(RideFullConfig(parameter_set="bmw320i", road="hump"))
    ratio, direction = structural_symmetry(hump)
    assert ratio < 1e-6 and abs(direction[list(hump.bounds.names).index("Ix")]) > 0.99
    road = RideFullProblem(RideFullConfig(parameter_set="bmw320i", road="iso8608",
                                          speed_kmh=60.0))
    assert max(cramer_rao(road)["crb_percent"]) < 1.0
