"""``problem=racecar``: the windows, the kernel against DOP853 with the logged inputs, the naive
predictor as the point to beat, and the keys."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vpid_vehicle.ride.racecar import NAIVE, VEHICLE, RacecarConfig, RacecarProblem, rms

from vpid_bench import ConfigError

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402

LINEAR = np.array([120e3, 200e3, 1000.0])
MAGIC = np.array([12.0, 1.4, 5000.0, 14.0, 1.5, 4000.0, 1000.0])


@pytest.fixture(scope="module")
def problem():
    return RacecarProblem(RacecarConfig())


def _rates(s, vx, delta, x, linear):
    m, lf, lr = VEHICLE["m"], VEHICLE["lf"], VEHICLE["lr"]
    vy, r = s
    af, ar = delta - np.arctan((vy + lf * r) / vx), np.arctan((lr * r - vy) / vx)
    if linear:
        ff, fr, Iz = x[0] * af, x[1] * ar, x[2]
    else:
        ff = x[2] * np.sin(x[1] * np.arctan(x[0] * af))
        fr = x[5] * np.sin(x[4] * np.arctan(x[3] * ar))
        Iz = x[6]
    return [(fr + ff * np.cos(delta)) / m - vx * r, (lf * ff * np.cos(delta) - lr * fr) / Iz]


@pytest.mark.parametrize("tyres, x", [("linear", LINEAR), ("magic_formula", MAGIC)])
def test_the_kernel_matches_dop853_with_the_logged_inputs(tyres, x):
    """Three windows of the fitted part, the logged speed and steer angle linear between
    samples: DOP853 at rtol 1e-11 (restarted at each sample) against RK4 at 10 ms (the
    default), within 2e-3 of each channel's rms (the first step from a logged state is a fast
    transient), and at 2.5 ms within 1e-5."""
    p = RacecarProblem(RacecarConfig(tyres=tyres))
    w = p.fitted
    pred = p._predict(x, w)[0]
    fine = RacecarProblem(RacecarConfig(tyres=tyres, substeps=16))
    pred_fine = fine._predict(x, fine.fitted)[0]
    for j in (0, w.starts.size // 2, w.starts.size - 1):
        s, ref = w.x0[j].copy(), [w.x0[j].copy()]
        for k in range(int(w.starts[j]), int(w.starts[j]) + w.H - 1):  # one interval each

            def f(t, y, k=k):
                vx = w.vx[k] + t / w.dt * (w.vx[k + 1] - w.vx[k])
                d = w.delta[k] + t / w.dt * (w.delta[k + 1] - w.delta[k])
                return _rates(y, vx, d, x, tyres == "linear")

            s = solve_ivp(f, (0, w.dt), s, method="DOP853", rtol=1e-11, atol=1e-13).y[:, -1]
            ref.append(s)
        ref = np.array(ref)
        scale = np.sqrt(np.mean(w.measured**2, axis=(0, 1)))
        assert np.all(np.abs(pred[j] - ref).max(axis=0) / scale < 2e-3), (tyres, j)
        assert np.all(np.abs(pred_fine[j] - ref).max(axis=0) / scale < 1e-5), (tyres, j)


def test_the_windows_are_fast_disjoint_and_in_their_half(problem):
    for w, second in ((problem.fitted, False), (problem.held_out, True)):
        N = w.vx.size
        assert np.all(np.diff(w.starts) >= w.H) and w.H == 25
        assert np.all((w.starts >= N // 2) if second else (w.starts + w.H <= N // 2))
        idx = w.starts[:, None] + np.arange(w.H)
        assert np.all(w.vx[idx] >= 5.0)
        assert np.array_equal(w.x0, w.measured[:, 0, :])


def test_the_naive_predictor_is_the_point_to_beat(problem):
    comp = problem.comparisons()[NAIVE]
    assert "x" not in comp and comp["metrics"]["val_rel_naive"] == 1.0
    w = problem.held_out
    assert comp["metrics"]["val_rms_vy"] == pytest.approx(rms(w.measured, w.naive())[0])
    m = problem.metrics(LINEAR)
    assert list(m) == sorted(m) and m["val_rel_naive"] == pytest.approx(
        0.5 * (m["val_rms_vy"] / comp["metrics"]["val_rms_vy"]
               + m["val_rms_r"] / comp["metrics"]["val_rms_r"]))
    assert problem.x_true is None


def test_a_magic_formula_tyre_at_small_slip_is_the_linear_one():
    """B C D equal to the linear stiffness and a large D: the two tyre models predict the
    same within 1e-3 of each channel's rms (the slip angles stay small)."""
    lin = RacecarProblem(RacecarConfig(tyres="linear"))
    mf = RacecarProblem(RacecarConfig(tyres="magic_formula"))
    Cf, Cr, Iz = LINEAR
    D = 1e7
    x_mf = np.array([Cf / (1.0 * D), 1.0, D, Cr / (1.0 * D), 1.0, D, Iz])
    a, b = lin._predict(LINEAR, lin.held_out)[0], mf._predict(x_mf, mf.held_out)[0]
    scale = np.sqrt(np.mean(a**2, axis=(0, 1)))
    assert np.all(np.abs(a - b).max(axis=(0, 1)) / scale < 1e-3)


def test_a_known_steer_delay_shifts_the_logged_angle():
    """0.08 s is two samples of the log (whose step is 0.04 s less 4e-8 s)."""
    p0 = RacecarProblem(RacecarConfig())
    p2 = RacecarProblem(RacecarConfig(steer_delay_s=0.08))
    assert np.allclose(p2.fitted.delta[10:], p0.fitted.delta[8:-2], atol=1e-8)


def test_residuals_objective_and_bad_rows():
    problem = RacecarProblem(RacecarConfig(objective="eq3"))
    X = np.array([LINEAR, LINEAR * 1.2, [np.nan, 1e5, 1e3]])
    f, R = problem.evaluate_with_residuals(X)
    g = problem.residual_groups()
    assert np.isclose(f[0], sum(np.linalg.norm(R[0][g == c]) for c in (0, 1)))
    assert np.isinf(f[2]) and np.isinf(R[2]).all()


@pytest.mark.parametrize("overrides, key", [
    ({"fit": "lvms", "validate": "lvms_second_half"}, "validate"),
    ({"fit": "putnam_first_half", "validate": "putnam_first_half"}, "validate"),
    ({"fit": "monza"}, "fit"), ({"tyres": "pacejka"}, "tyres"),
    ({"horizon_s": 0.04}, "horizon_s"), ({"steer_delay_s": -0.1}, "steer_delay_s"),
    ({"objective": "ml"}, "objective"), ({"min_speed": 30.0, "horizon_s": 10}, "min_speed")])
def test_bad_keys_name_themselves(overrides, key):
    with pytest.raises(ConfigError, match=rf"^problem\.{key}="):
        RacecarProblem(RacecarConfig(**overrides))


@pytest.mark.slow  # about 10 s of CPU: the job's analysis and report
def test_the_command_ranks_by_held_out_error_without_nore(in_tmp):
    import json

    proc = run_cli(["problem=racecar", "optimizer=de4", "runs=1", "problem.ps=4",
                    "problem.iterations=1", "hydra.run.dir=out"], in_tmp, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (path,) = (in_tmp / "out" / "records").glob("run-*.json")
    rec = json.loads(path.read_text())
    assert set(rec["result"]["metrics"]) == {"val_rel_naive", "val_rms_r", "val_rms_vy"}
    rows = json.loads((in_tmp / "out" / "comparisons.json").read_text())["rows"]
    assert rows[0]["name"] == NAIVE and rows[0]["metrics"]["val_rel_naive"] == 1.0


@pytest.mark.parametrize("name", ["putnam", "lvms"])
def test_the_logged_yaw_rate_follows_the_steer_angle_a_third_of_a_second_late(name):
    """Where the car runs at 5 m/s or more, the yaw rate correlates best with the kinematic
    ``vx delta / L`` 7 to 10 samples (0.28-0.40 s) later: the lag docs/measured.md names."""
    from vpid_vehicle.ride import racecar, third_party

    log = third_party.read_racecar_log(racecar.LOGS[name], None)
    fast = np.flatnonzero(log.vx > 5)
    a, b = fast[0], fast[-1]
    kin = log.vx[a:b] * log.delta[a:b] / (VEHICLE["lf"] + VEHICLE["lr"])
    r = log.r[a:b]
    corr = [np.corrcoef(kin[:kin.size - k], r[k:])[0, 1] for k in range(15)]
    assert 7 <= int(np.argmax(corr)) <= 10


def test_the_logged_lateral_velocity_is_not_the_models():
    """On Putnam the logged vy follows 1.9 r + 0.14 m/s (least squares over the samples at
    5 m/s or more): a lever arm and an offset the single-track model at the centre of gravity
    has no term for."""
    from vpid_vehicle.ride import racecar, third_party

    log = third_party.read_racecar_log(racecar.LOGS["putnam"], None)
    fast = log.vx > 5
    slope, offset = np.polyfit(log.r[fast], log.vy[fast], 1)
    assert 1.8 < slope < 2.1 and 0.12 < offset < 0.16
