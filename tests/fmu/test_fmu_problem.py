"""problem=fmu on FMUs built from the project's own C source (plugins/vpid_fmu/sources): the
quarter car against problem=ride_quarter, the input handling against a record fmpy made, FMI
2.0 co-simulation and model exchange, FMI 3.0 co-simulation, and an identification whose
intervals hold the truth."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("fmpy")

from vpid_fmu import example  # noqa: E402
from vpid_fmu.problem import FmuConfig, FmuProblem  # noqa: E402

from vpid_bench.params import build_dataclass  # noqa: E402

TRUTH = {"ms": 280.0, "mu": 33.0, "ks": 17000.0, "cs": 1300.0}
X_TRUE = np.array(list(TRUTH.values()))
GOLDEN = np.array([250.0, 37.5, 15825.0, 1500.0])
NOISE = 0.03


def make(fmu, record, **keys) -> FmuProblem:
    cfg = build_dataclass(FmuConfig, {"fmu": str(fmu), "reference": {"file": str(record)},
                                      **keys}, "problem")
    return FmuProblem(cfg)


@pytest.fixture(scope="module")
def record(example_fmu, tmp_path_factory):
    """4 s at 500 Hz, 3 % noise, made by fmpy's simulate_fmu at 1e-4 s (not our importer)."""
    out = tmp_path_factory.mktemp("record") / "record.csv"
    return example.write_record(example_fmu("fmi2"), out, TRUTH, duration=4.0, noise=NOISE)


@pytest.fixture(scope="module")
def ride_record(tmp_path_factory):
    """problem=ride_quarter's own record of the golden car on its hump (exact first-order
    hold, no noise, 500 Hz) as a CSV the FMU problem reads."""
    from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem

    cfg = build_dataclass(RideQuarterConfig, {
        "noise_level": 0.0, "truth": "set", "record": "exact", "record_substeps": 1,
        "dt": 0.002, "duration_s": 3.0, "road": "hump", "sensors": "body_wheel"}, "problem")
    ride = RideQuarterProblem(cfg)
    out = tmp_path_factory.mktemp("ride") / "ride.csv"
    np.savetxt(out, np.column_stack([ride.t, ride.u[:, 0], ride.clean[0], ride.clean[1]]),
               delimiter=",", header="t,h,zsdd,zudd", comments="", fmt="%.17g")
    return out, ride.clean


def _rel_rms(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean((a - b) ** 2, axis=-1)) / np.sqrt(np.mean(b**2, axis=-1))


def test_the_quarter_car_fmu_matches_ride_quarter(example_fmu, ride_record):
    """The same quarter car (golden car, kt 163,250 N/m, ct 0) on the same hump: the FMU's
    co-simulation (RK4 on 1e-4 s steps, the input's slope given) within 1e-7 of ride_quarter's
    exact first-order-hold record (relative rms per channel), and its model exchange
    (Dormand-Prince, rtol 1e-6) within 1e-4."""
    path, clean = ride_record
    cs = make(example_fmu("fmi2"), path).computed(GOLDEN[None])[0]
    assert np.all(_rel_rms(cs, clean) < 1e-7), _rel_rms(cs, clean)
    me = make(example_fmu("fmi2"), path, interface="me").computed(GOLDEN[None])[0]
    assert np.all(_rel_rms(me, clean) < 1e-4), _rel_rms(me, clean)


def _noise_ratio(problem: FmuProblem) -> np.ndarray:
    """Each compared channel's rms residual at the truth over the record's noise sigma."""
    y = problem.measured
    fitted = problem.computed(X_TRUE[None])[0]
    clean_rms = np.sqrt(np.mean(y**2, axis=1) / (1 + NOISE**2))
    return np.sqrt(np.mean((y - fitted) ** 2, axis=1)) / (NOISE * clean_rms)


def test_the_default_input_handling_reproduces_the_record_to_noise_level(example_fmu, record,
                                                                          caplog):
    """The record (fmpy at 1e-4 s steps, the input linear in time) is reproduced at the truth to
    its noise (residual rms within 10 % of sigma) by the default, the input's slope given;
    holding the input over each 2 ms step leaves residuals 1.4 (body) and 4.4 (wheel) times
    the noise."""
    with caplog.at_level("INFO"):
        default = make(example_fmu("fmi2"), record)
    assert default.mode == "derivatives"
    assert any("slope over a step given" in r.getMessage() for r in caplog.records)
    ratio = _noise_ratio(default)
    assert np.all((ratio > 0.9) & (ratio < 1.1)), ratio
    held = _noise_ratio(make(example_fmu("fmi2"), record, inputs="hold", substeps=1))
    assert np.all(held > 1.3) and held.max() > 3.0, held  # body 1.39x, wheel 4.39x
    # the FMU that cannot interpolate: held sub-steps, said so; 20 of them come close
    fine = make(example_fmu("nointerp"), record, substeps=20)
    assert fine.mode == "hold" and "cannot interpolate" in fine.mode_info
    assert np.all(_noise_ratio(fine) < 1.2), _noise_ratio(fine)


def test_fmi3_co_simulation_equals_fmi2_with_the_input_held(example_fmu, record):
    """FMI 3.0 (no input derivatives: held sub-steps) runs the same model as FMI 2.0 with
    inputs=hold: equal outputs to 1e-12."""
    three = make(example_fmu("fmi3"), record)
    assert three.mode == "hold" and "FMI 3.0" in three.mode_info
    two = make(example_fmu("fmi2"), record, inputs="hold")
    a, b = three.computed(X_TRUE[None]), two.computed(X_TRUE[None])
    assert np.all(np.isfinite(a)) and np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b))


def test_an_identification_holds_the_truth_in_its_intervals(example_fmu, record):
    """Least squares from the box's centre recovers the parameters the record was made with:
    every one inside its 95 % Jacobian interval; the known tyre is listed with its source."""
    from scipy.optimize import least_squares

    from vpid_bench.analysis.intervals import jacobian_intervals

    p = make(example_fmu("fmi2"), record)
    lo, hi = p.bounds.lower, p.bounds.upper
    fit = least_squares(lambda z: p.residuals((lo + z * (hi - lo))[None])[0],
                        np.full(4, 0.5), bounds=(0, 1), x_scale=1.0)
    x = lo + fit.x * (hi - lo)
    iv = jacobian_intervals(p, x)
    lower, upper = np.array(iv["lower"]), np.array(iv["upper"])
    assert np.all((lower <= X_TRUE) & (X_TRUE <= upper)), (x, lower, upper)
    assert np.all(upper - lower < 0.1 * X_TRUE)  # the record determines each one
    known = p.describe()["known"]
    assert known == [{"name": "kt", "value": 163250.0, "unit": "N/m",
                      "source": "the FMU's start value"}]


def test_a_known_quantity_is_set_as_a_start_value(example_fmu, record):
    """problem.known.kt changes the simulation (the tyre is stiffer) and is listed as set by
    you; the residual at the truth grows."""
    stiff = make(example_fmu("fmi2"), record, known={"kt": 200000.0})
    assert stiff.describe()["known"][0] == {"name": "kt", "value": 200000.0, "unit": "N/m",
                                            "source": "set by you (problem.known)"}
    assert np.all(_noise_ratio(stiff) > 1.5)


def test_a_failing_simulation_is_an_infinite_objective(example_fmu, record):
    """A candidate the FMU cannot run (a zero mass: the derivative divides by it) or a NaN
    gives inf, and the next candidate runs again on the reset instance."""
    p = make(example_fmu("fmi2"), record)
    f = p.evaluate(np.array([[0.0, 37.5, 15825.0, 1500.0], [np.nan] * 4, X_TRUE]))
    assert not np.isfinite(f[1]) and np.isfinite(f[2])
    assert f[2] == p.evaluate(X_TRUE[None])[0]
