"""``problem=emps``: the shipped records (checksums), the exact plant step against independent
solutions, the closed loop against a fine fixed-step integration, the controller timing and
pulses read from the logs, and the published estimate against the measured position."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from vpid_emps import records
from vpid_emps.loop import plant_step
from vpid_emps.problem import PUBLISHED, VMAX, EmpsConfig, EmpsProblem

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402

from vpid_bench import ConfigError, VpidBenchError, file_sha256


@pytest.fixture(scope="module")
def emps():
    return EmpsProblem(EmpsConfig())


# --- the shipped files --------------------------------------------------------------------
def test_the_shipped_records_have_their_published_checksums():
    for name, expected in records.SHA256.items():
        assert file_sha256(records.verified(name)) == expected
    assert (records.DATA / "LICENSE").read_text().startswith(" " * 33 + "Apache License")


def test_an_altered_record_is_one_error_naming_the_file_and_the_checksum(tmp_path):
    name = "DATA_EMPS.mat"
    data = bytearray((records.DATA / name).read_bytes())
    data[-1] ^= 1
    (tmp_path / name).write_bytes(bytes(data))
    with pytest.raises(VpidBenchError) as err:
        records.load(name, tmp_path)
    message = str(err.value)
    assert "\n" not in message and name in message and records.SHA256[name] in message


def test_a_missing_record_is_one_error_naming_the_checksum(tmp_path):
    with pytest.raises(VpidBenchError, match=records.SHA256["DATA_EMPS_PULSES.mat"]):
        records.load("DATA_EMPS_PULSES.mat", tmp_path)


def test_an_intact_copy_reads_the_same(tmp_path):
    shutil.copy(records.DATA / "DATA_EMPS.mat", tmp_path)
    a, b = records.load("DATA_EMPS.mat", tmp_path), records.load("DATA_EMPS.mat")
    assert np.array_equal(a.qm, b.qm) and a.gtau == b.gtau == pytest.approx(35.15065188)
    assert (a.kp, a.kv) == (160.18, 243.45) and a.t.size == 24841


def test_a_bad_controller_delay_or_record_names_the_key():
    with pytest.raises(ConfigError, match=r"problem\.controller_delay=2 .*0 or 1"):
        EmpsConfig(controller_delay=2)
    with pytest.raises(ConfigError, match=r"problem\.fit_record='both' .*estimation or pulses"):
        EmpsConfig(fit_record="both")


def test_fitting_the_pulses_record_swaps_the_records():
    p = EmpsProblem(EmpsConfig(fit_record="pulses"))
    assert p.estimation.record.name == "DATA_EMPS_PULSES.mat"
    assert p.validation.record.name == "DATA_EMPS.mat" and p.validation.pulse_volts == 0.0
    m = p.metrics(PUBLISHED)
    assert m["val_rms_um"] == pytest.approx(np.sqrt(EmpsProblem(EmpsConfig()).evaluate(
        PUBLISHED[None])[0]), rel=1e-12)


# --- the plant, step by step --------------------------------------------------------------
M, FV, FC = 95.0, 200.0, 20.0


def _ode(net):
    return lambda t, s: [s[1], (net - FV * s[1] - FC * np.sign(s[1])) / M]


def _step(q0, v0, net, h):
    b = FV / M
    return plant_step(q0, v0, net, FV, FC, b, h, -np.expm1(-b * h))


@pytest.mark.parametrize("v0, net", [(0.05, 150.0), (-0.02, -90.0), (0.08, -10.0)])
def test_a_step_without_a_sign_change_matches_solve_ivp(v0, net):
    """Over 1 ms and over 50 ms (no zero crossing in either): within 1e-12 m and 1e-10 m/s of
    DOP853 at rtol 1e-12."""
    for h in (1e-3, 5e-2):
        ref = solve_ivp(_ode(net), (0, h), [0.1, v0], method="DOP853", rtol=1e-12,
                        atol=1e-15).y[:, -1]
        q, v = _step(0.1, v0, net, h)
        assert np.sign(v) == np.sign(v0)
        assert abs(q - ref[0]) < 1e-12 and abs(v - ref[1]) < 1e-10


def test_a_step_through_zero_velocity_matches_solve_ivp_with_an_event():
    """Moving forward against a net force that reverses it: DOP853 stopped at v = 0 by an
    event, then continued from rest in the direction of the net force (|net| > Fc)."""
    q0, v0, net, h = 0.0, 0.01, -150.0, 2e-2
    stop = lambda t, s: s[1]  # noqa: E731
    stop.terminal = True
    first = solve_ivp(_ode(net), (0, h), [q0, v0], method="DOP853", rtol=1e-12, atol=1e-15,
                      events=stop)
    tc, qc = first.t_events[0][0], first.y_events[0][0][0]
    second = solve_ivp(lambda t, s: [s[1], (net - FV * s[1] + FC) / M], (tc, h), [qc, 0.0],
                       method="DOP853", rtol=1e-12, atol=1e-15).y[:, -1]
    q, v = _step(q0, v0, net, h)
    assert v < 0 and abs(q - second[0]) < 1e-12 and abs(v - second[1]) < 1e-10


def test_static_friction_holds_a_carriage_at_rest_by_hand():
    """From rest, a net force within Fc moves nothing; beyond it the velocity is
    ``(net - Fc) / Fv (1 - exp(-Fv h / M))`` (computed here by hand)."""
    assert _step(0.3, 0.0, 19.9, 1e-3) == (0.3, 0.0)
    assert _step(0.3, 0.0, -20.0, 1e-3) == (0.3, 0.0)
    h, net = 1e-3, 50.0
    v_hand = (net - FC) / FV * (1 - np.exp(-FV * h / M))
    assert _step(0.3, 0.0, net, h)[1] == pytest.approx(v_hand, rel=1e-12)
    # moving slowly against a force within Fc: it stops and stays
    q, v = _step(0.3, 1e-4, -5.0, 1e-2)
    assert v == 0.0 and q > 0.3


# --- the closed loop ----------------------------------------------------------------------
def _fine_loop(problem: EmpsProblem, x: np.ndarray, K: int, sub: int) -> np.ndarray:
    """The loop of the module docstring written out again, its plant integrated by Heun's
    method at dt / sub with the friction of Simulink's block (sign(0) = 0)."""
    rec, loop = problem.estimation.record, problem.estimation
    Mx, Fv, Fc, off = x
    dt = records.DT
    h = dt / sub
    q, v = rec.qm[0], loop.v0
    q_prev, qf_prev = q - v * dt, q - 1.5 * v * dt
    out = np.empty(K)
    for k in range(K):
        out[k] = q
        qf = 0.5 * (q + q_prev)
        c = rec.kv * (rec.kp * (rec.qg[k] - q) - (qf - qf_prev) / dt)
        qf_prev, q_prev = qf, q
        F = rec.gtau * min(max(c, -VMAX), VMAX) - off
        for _ in range(sub):
            a1 = (F - Fv * v - Fc * np.sign(v)) / Mx
            vp = v + h * a1
            a2 = (F - Fv * vp - Fc * np.sign(vp)) / Mx
            q += 0.5 * h * (v + vp)
            v += 0.5 * h * (a1 + a2)
    return out


def test_the_loop_matches_a_fine_fixed_step_integration(emps):
    """The first 3.3 s (a stop at 0.445 s, the first reversal at 3.1 s): the exact
    piecewise solution against Heun's method at 20 µs and 10 µs. The fixed-step solution
    converges to ours at first order (the friction is discontinuous): within 2e-8 m at 10 µs
    (1 % of the fit's rms error, below the encoder's 0.05 µm quantum), about twice that
    at 20 µs."""
    K = 3300
    ours = emps.estimation.simulate(PUBLISHED[None])[0][0, :K]
    d100 = np.abs(_fine_loop(emps, PUBLISHED, K, 100) - ours).max()
    d50 = np.abs(_fine_loop(emps, PUBLISHED, K, 50) - ours).max()
    assert d100 < 2e-8
    assert 1.5 < d50 / d100 < 3


def test_the_logged_voltage_is_the_controller_of_the_same_sample():
    """The controller recomputed from the measured positions matches the logged voltage
    within 0.013 V at every sample (past the first two, whose past is not recorded) of the
    estimation record; one sample
    later it misses by more than 0.3 V."""
    rec = records.load("DATA_EMPS.mat")
    c = rec.controller()
    assert np.abs(rec.vir - c)[2:].max() < 0.013
    assert np.abs(rec.vir[1:] - c[:-1]).max() > 0.3


def test_the_pulses_add_a_constant_voltage_where_the_column_says(emps):
    """During a pulse the logged voltage exceeds the controller's by 5.07 V (spread below
    0.01 V; the column holds 5), elsewhere by nothing (within 0.04 V)."""
    rec = emps.validation.record
    on = rec.pulse != 0
    extra = rec.vir - rec.controller()
    assert set(np.unique(rec.pulse)) == {0.0, 5.0} and 0.3 < on.mean() < 0.7
    assert emps.validation.pulse_volts == pytest.approx(5.07, abs=0.005)
    assert np.std(extra[on]) < 0.01 and np.abs(extra[~on][2:]).max() < 0.04
    assert emps.estimation.pulse_volts == 0.0


def test_the_published_estimate_reproduces_the_measured_position(emps):
    """Published estimate in our loop: within 1.7 µm rms on the estimation record and 2 µm on
    the validation record (the position spans 246 mm); the voltage within 0.1 V rms."""
    f = emps.evaluate(PUBLISHED[None])[0]
    assert np.sqrt(f) < 1.7
    m = emps.metrics(PUBLISHED)
    assert m["val_rms_um"] < 2.0 and m["val_voltage_rms_V"] < 0.1
    assert 0 < m["val_unexplained_pct"] < 0.003


def test_a_fit_moves_off_the_published_estimate_and_the_delay_moves_fv():
    """Output error from the published estimate (scipy's least_squares on the problem's own
    residuals): a lower objective; with one sample's controller delay Fv moves 3-6 %."""
    from scipy.optimize import least_squares

    fits = {}
    for delay in (0, 1):
        p = EmpsProblem(EmpsConfig(controller_delay=delay))
        sol = least_squares(lambda x, p=p: p.residuals(x[None])[0], PUBLISHED,
                            x_scale=np.abs(PUBLISHED), diff_step=1e-4, max_nfev=40)
        fits[delay] = sol.x
        assert p.evaluate(sol.x[None])[0] < p.evaluate(PUBLISHED[None])[0]
    assert 0.03 < fits[1][1] / fits[0][1] - 1 < 0.06


# --- the problem's contract ---------------------------------------------------------------
def test_the_problem_has_no_truth_and_a_comparison_point(emps):
    assert emps.x_true is None
    assert emps.bounds.names == ("M", "Fv", "Fc", "offset")
    assert np.all(emps.bounds.lower < PUBLISHED) and np.all(PUBLISHED < emps.bounds.upper)
    comp = emps.comparisons()["published estimate"]
    assert comp["x"] == PUBLISHED.tolist() and "IDIM-LS" in comp["note"]
    assert list(emps.metrics(PUBLISHED))[0] == "val_rms_um"


def test_residuals_and_objective_agree_and_bad_rows_are_inf(emps):
    X = np.array([PUBLISHED, PUBLISHED * 1.05, [np.nan, 200, 20, 0], [-1, 200, 20, 0]])
    f, R = emps.evaluate_with_residuals(X)
    assert np.allclose(f[:2], np.sum(R[:2] ** 2, axis=1), rtol=1e-12)
    assert np.isinf(f[2:]).all() and np.isinf(R[2:]).all()
    assert np.array_equal(emps.evaluate(X[1:2]), f[1:2])  # a row's value is its own
    assert emps.residual_groups().shape == (R.shape[1],)


def test_the_command_fits_the_rig_and_records_held_out_errors_not_nore(in_tmp):
    """``vpid-bench problem=emps`` from the installed package: each record holds the held-out
    metrics (no NoRE, no truth) and the published estimate as a comparison."""
    import json

    proc = run_cli(["problem=emps", "optimizer=de4", "runs=1", "problem.ps=4",
                    "problem.iterations=1", "hydra.run.dir=out"], in_tmp)
    assert proc.returncode == 0, proc.stderr[-2000:]
    (path,) = (in_tmp / "out" / "records").glob("run-*.json")
    rec = json.loads(path.read_text())
    assert set(rec["result"]["metrics"]) == {"val_rms_um", "val_unexplained_pct",
                                             "val_voltage_rms_V"}
    info = rec["problem"]["info"]
    assert "truth" not in info and "f_at_true" not in info
    assert rec["result"]["intervals"]["method"] == "jacobian"
    rows = json.loads((in_tmp / "out" / "comparisons.json").read_text())["rows"]
    assert rows[0]["name"] == "published estimate" and rows[0]["x"] == PUBLISHED.tolist()
    assert rows[0]["metrics"]["val_rms_um"] < 2.0
    report = (in_tmp / "out" / "report" / "report.md").read_text()
    assert "## EMPS: identified beside the published estimate" in report
    assert "203.5" in report and "No truth" in report


def test_a_bad_key_is_refused_before_any_job(in_tmp):
    proc = run_cli(["problem=emps", "problem.controller_delay=3", "hydra.run.dir=out"], in_tmp)
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1
    assert lines[0].startswith("error: problem.controller_delay=3")


def test_the_fit_diagnostics_flag_the_rigs_correlated_residuals(emps):
    """At the published estimate: one channel ``q``, residuals far from white (lag 1 near 1),
    the reference position as the loop's input, the held-out error far below the naive
    predictor's (the position equal to its reference), and the robust interval several times
    the white one; the first screen's objective has a unit and the caveat of
    docs/measured.md."""
    from vpid_bench.analysis.diagnostics import problem_diagnostics

    d = problem_diagnostics(emps, PUBLISHED)
    (g,) = d["groups"]
    assert g["name"] == "q" and g["correlated"] and g["lag1"] > 0.99
    assert set(g["cross"]) == {"qg"} and g["rms_over_signal"] < 1e-3
    held = d["held_out"]
    assert held["unit"] == "µm" and held["error"] < 0.01 * held["naive"]
    ratio = np.array(d["intervals"]["robust"]["se"]) / np.array(d["intervals"]["se"])
    assert np.all(ratio > 3)
    info = emps.describe()
    assert info["objective"]["unit"] == "µm²" and "docs/measured.md" in info["caveat"]
