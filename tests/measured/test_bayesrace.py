"""``problem=bayesrace``: the records are the simulator's explicit Euler (checked by an Euler step
written out here), our continuous-time kernel against DOP853, what the discretisation costs at
the truth, and the problem's contract."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vpid_vehicle.ride import bayesrace, third_party
from vpid_vehicle.ride.bayesrace import SIMULATOR, VEHICLE, BayesraceConfig, BayesraceProblem

from vpid_bench import ConfigError

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402


def rates(s: np.ndarray, d: float, delta: float) -> np.ndarray:
    """The simulator's equations for ``s = (vx, vy, r)`` with numpy's atan2, sin and atan."""
    c = {k: v[0] for k, v in SIMULATOR.items()}
    m, lf, lr = VEHICLE["m"], VEHICLE["lf"], VEHICLE["lr"]
    vx, vy, r = s

    def mf(a, B, C, D, E):
        return D * np.sin(C * np.arctan(B * a - E * (B * a - np.arctan(B * a))))

    af = delta - np.arctan2(lf * r + vy, abs(vx)) + c["Shf"]
    ar = np.arctan2(lr * r - vy, abs(vx)) + c["Shr"]
    ffy = c["Svf"] + mf(af, c["Bf"], c["Cf"], c["Df"], c["Ef"])
    fry = c["Svr"] + mf(ar, c["Br"], c["Cr"], c["Dr"], c["Er"])
    frx = (c["Cm1"] - c["Cm2"] * vx) * d - c["Cr0"] - c["Cr2"] * vx**2
    return np.array([(frx - ffy * np.sin(delta)) / m + vy * r,
                     (fry + ffy * np.cos(delta)) / m - vx * r,
                     (ffy * lf * np.cos(delta) - fry * lr) / c["Iz"]])


@pytest.fixture(scope="module")
def problem():
    return BayesraceProblem(BayesraceConfig())


@pytest.mark.parametrize("track", sorted(bayesrace.TRACKS))
def test_the_records_are_the_simulators_euler_step_at_50_hz(track):
    """From every sample, one explicit Euler step of 20 ms with the simulator's coefficients
    gives the next sample within 1e-12 of each channel's scale."""
    rec = third_party.read_simulator_record(bayesrace.TRACKS[track], None)
    s = rec.states
    step = np.stack([s[:, k] + bayesrace.DT * rates(s[:, k], rec.drive[k], rec.steer[k])
                     for k in range(s.shape[1] - 1)], axis=1)
    scale = np.abs(s).max(axis=1, keepdims=True)
    assert np.abs(step - s[:, 1:]).max() / scale.min() < 1e-12


def test_the_kernel_matches_dop853_on_the_records_inputs(problem):
    """The first 4 s of the ETHZ record's inputs (zero-order hold), from its first state,
    against DOP853 at rtol 1e-11: RK4 at 2 ms (the default) within 1e-5 of each channel's rms,
    and at 0.5 ms more than 100 times closer (fourth order: 256)."""
    rec = problem.fit.record
    K = 200
    s, ref = rec.states[:, 0].copy(), [rec.states[:, 0].copy()]
    for k in range(K - 1):
        sol = solve_ivp(lambda t, y, k=k: rates(y, rec.drive[k], rec.steer[k]),
                        (0, bayesrace.DT), s, method="DOP853", rtol=1e-11, atol=1e-12)
        s = sol.y[:, -1]
        ref.append(s)
    ref = np.array(ref).T
    scale = np.sqrt(np.mean(ref**2, axis=1))
    errors = {}
    for sub in (10, 40):
        fine = BayesraceProblem(BayesraceConfig(substeps=sub))
        ours = fine.fit.simulate(problem.x_true[None])[0][:, :K]
        errors[sub] = np.abs(ours - ref).max(axis=1) / scale
    assert np.all(errors[10] < 1e-5)
    assert np.all(errors[10] / errors[40] > 100)


def test_at_the_truth_the_continuous_model_misses_the_euler_record(problem):
    """The discretisation's cost: the continuous model with the simulator's own coefficients
    misses the yaw rate by more than 10 % of its rms (the Euler record alternates in sign
    where the car is slow), and the fit moves away from the truth."""
    from scipy.optimize import least_squares

    x_true = problem.x_true
    sim = problem.fit.simulate(x_true[None])[0]
    y = problem.measured
    miss = np.sqrt(np.mean((y - sim) ** 2, axis=1)) / np.sqrt(np.mean(y**2, axis=1))
    assert miss[2] > 0.10 and problem.describe()["f_at_true"] > 0
    b = problem.bounds
    sol = least_squares(lambda x: problem.residuals(x[None])[0], x_true, x_scale=x_true,
                        bounds=(b.lower, b.upper), max_nfev=30)
    assert problem.evaluate(sol.x[None])[0] < problem.evaluate(x_true[None])[0]
    assert problem.metrics(sol.x)["NoRE"] > 10


def test_the_problem_has_a_truth_and_held_out_metrics(problem):
    x = problem.x_true
    assert problem.bounds.names == bayesrace.IDENTIFIED
    assert np.all(problem.bounds.lower < x) and np.all(x < problem.bounds.upper)
    m = problem.metrics(x)
    assert list(m) == ["NoRE", "val_rms_vx", "val_rms_vy", "val_rms_r"] and m["NoRE"] == 0
    assert sorted(m)[0] == "NoRE"  # first also as records store them (by name)
    X = np.array([x, x * 1.1, np.r_[x[:-1], -1.0]])
    f, R = problem.evaluate_with_residuals(X)
    assert problem.config.objective == "ml_profiled"
    assert np.isinf(f[2]) and np.isinf(R[2]).all() and np.all(np.isfinite(f[:2]))
    # ml_profiled: the geometric mean of the channels' relative rms misfits, ||R|| = sqrt(m) f
    F = problem.fisher_residuals(X[1:2])[0].reshape(3, -1)
    rel = np.sqrt(np.mean(F**2, axis=1) * F.shape[1])  # rms(y - g) / rms(y) per channel
    assert np.isclose(f[1], np.exp(np.mean(np.log(rel))), rtol=1e-12)
    assert np.isclose(np.linalg.norm(R[1]), np.sqrt(R.shape[1]) * f[1])
    eq3 = BayesraceProblem(BayesraceConfig(objective="eq3"))
    f3, R3 = eq3.evaluate_with_residuals(X[1:2])
    groups = eq3.residual_groups()
    assert groups.shape == (R3.shape[1],) and set(groups) == {0, 1, 2}
    assert np.isclose(f3[0], sum(np.linalg.norm(R3[0][groups == g]) for g in range(3)))


@pytest.mark.parametrize("key, value, words", [
    ("track", "Mobil", "ETHZ or ETHZMobil"), ("substeps", 0, "[1, 100]"),
    ("objective", "ml", "eq3, ols or ml_profiled")])
def test_bad_keys_name_themselves(key, value, words):
    with pytest.raises(ConfigError, match=rf"problem\.{key}=.*{__import__('re').escape(words)}"):
        BayesraceConfig(**{key: value})


@pytest.mark.slow  # 15 s of CPU: the job's analysis polishes each objective's optimum
def test_the_command_records_nore_against_the_simulators_coefficients(in_tmp):
    import json

    proc = run_cli(["problem=bayesrace", "optimizer=de4", "runs=1", "problem.ps=4",
                    "problem.iterations=1", "hydra.run.dir=out"], in_tmp, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (path,) = (in_tmp / "out" / "records").glob("run-*.json")
    rec = json.loads(path.read_text())
    assert set(rec["result"]["metrics"]) == {"NoRE", "val_rms_r", "val_rms_vx", "val_rms_vy"}
    assert rec["problem"]["info"]["truth"] == [SIMULATOR[k][0] for k in bayesrace.IDENTIFIED]
