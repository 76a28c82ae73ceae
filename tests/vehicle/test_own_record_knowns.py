"""Stated quantities and boxes (``problem.known.<name>``, ``problem.bounds.<name>``,
plugins/vpid_vehicle/knowns.py) and strict records with a column mapping
(``problem.reference.columns``, ``ignore``, ``input``), and issue 41's first Done-when item:
a quarter-car record made by a richer car than the fitted one, read with a logger's column
names and the tyre stated, gives ms, mu and ks within 2 %, and its first screen names the
tyre used."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from vpid_vehicle.ride.model import Wheel, wheel_inputs
from vpid_vehicle.ride.problem import RecordFileConfig
from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem

from vpid_bench import ConfigError

G = 9.80665
#: The car that makes the record: its quarter (kg, kg, N/m, N s/m) and tyre (N/m).
TRUTH = {"ms": 300.0, "mu": 40.0, "ks": 29500.0, "cs": 1700.0}
KT = 210000.0
#: Its spring is progressive (``ks d (1 + PROGRESSION (d / 0.05 m)^2)``: 10 % stiffer at a
#: 5 cm stroke) and its damper 1.5:1 in rebound against compression (``cs (1 +- ASYMMETRY)``);
#: the fitted model's are linear.
PROGRESSION, ASYMMETRY = 0.1, 0.2
#: The record: 12 s at 500 Hz. Why this design: at 3 s the estimate of ks moved from -4 % to
#: +2 % with the road (the record holds too few body cycles, and the model error projects
#: onto ks differently on each road); at 12 s on eight roads ks lies within -0.5 % to +1.8 %
#: (the linear rate the progressive spring has over the strokes of a class C road), ms and
#: mu within 0.7 % (test_the_design_holds_on_eight_roads, slow).
DURATION_S = 12.0


def _rates(s: np.ndarray, h: float, hd: float) -> np.ndarray:
    zs, zu, vs, vu = s
    d, v = zs - zu, vs - vu
    spring = TRUTH["ks"] * d * (1 + PROGRESSION * (d / 0.05) ** 2)
    damper = TRUTH["cs"] * (1 + ASYMMETRY if v > 0 else 1 - ASYMMETRY) * v
    tyre = KT * (zu - h)
    return np.array([vs, vu, -(spring + damper) / TRUTH["ms"],
                     (spring + damper - tyre) / TRUTH["mu"]])


def richer_quarter(u: np.ndarray, dt: float) -> np.ndarray:
    """Body and wheel accelerations ``(N, 2)`` of the richer car from rest, driven by ``u =
    [h, h']`` linear between samples, by the classical Runge-Kutta method at ``dt`` (written
    here, independently of the plugin's models)."""
    s, out = np.zeros(4), np.empty((u.shape[0], 2))
    for k in range(u.shape[0]):
        r = _rates(s, u[k, 0], u[k, 1])
        out[k] = r[2], r[3]
        if k + 1 == u.shape[0]:
            break
        hm, dm = 0.5 * (u[k] + u[k + 1])
        k2 = _rates(s + 0.5 * dt * r, hm, dm)
        k3 = _rates(s + 0.5 * dt * k2, hm, dm)
        k4 = _rates(s + dt * k3, u[k + 1, 0], u[k + 1, 1])
        s = s + dt / 6 * (r + 2 * k2 + 2 * k3 + k4)
    return out


def write_logger_record(folder: Path, road_seed: int = 7, noise_seed: int = 8) -> Path:
    """A logger's record of the richer car on an ISO 8608 class C road at 60 km/h:
    :data:`DURATION_S` at 500 Hz from t = 12.3 s (made at 5 kHz), 3 % noise per channel, the
    logger's names and units (``time [s]``, ``body_acc [m/s^2]``, ``wheel_acc [g]``,
    ``road [mm]``)."""
    fine, sub = 0.0002, 10
    u = wheel_inputs(RideQuarterConfig(road="iso8608", speed_kmh=60.0, duration_s=DURATION_S),
                     (Wheel(0, 0.0),), fine, np.random.default_rng(road_seed))
    y, u = richer_quarter(u, fine)[::sub], u[::sub]
    y = y + 0.03 * np.sqrt(np.mean(y**2, axis=0)) * np.random.default_rng(
        noise_seed).standard_normal(y.shape)
    t = 12.3 + np.arange(y.shape[0]) * fine * sub
    path = folder / "my_car.csv"
    rows = (",".join(repr(float(v)) for v in (t[k], y[k, 0], y[k, 1] / G, 1e3 * u[k, 0]))
            for k in range(t.size))
    path.write_text("time [s],body_acc [m/s^2],wheel_acc [g],road [mm]\n"
                    + "\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="module")
def logger_record(tmp_path_factory) -> Path:
    """The record of :func:`write_logger_record` on road 7."""
    return write_logger_record(tmp_path_factory.mktemp("logger"))


def _main(argv: list[str], capsys) -> tuple[int, str]:
    """``vpid-bench <argv>`` in this process: (exit code, stderr)."""
    from vpid_bench.shell.main import main

    try:
        main(argv)
    except SystemExit as exc:
        return int(exc.code or 0), capsys.readouterr().err
    return 0, capsys.readouterr().err


def _plan(argv: list[str]):
    """The pre-flight's plan of ``vpid-bench <argv>``."""
    from vpid_bench.plugins import Registry
    from vpid_bench.shell.argv import parse_command_line
    from vpid_bench.shell.callbacks import ensure_job_dir_resolver
    from vpid_bench.shell.config_store import register_configs
    from vpid_bench.shell.preflight import plan

    registry = Registry()
    register_configs(registry)
    ensure_job_dir_resolver()
    return plan(parse_command_line(argv), registry)


LOGGER = {"t": "time", "zsdd": "body_acc", "zudd": "wheel_acc", "h": "road"}


def _fit(tmp_path: Path, config: RideQuarterConfig) -> Path:
    """One least-squares run on ``config`` in this process, and its short report."""
    from vpid_bench.experiment import run_job
    from vpid_bench.plugins import Registry
    from vpid_bench.report.build import build_report
    from vpid_bench.spec import Job, JobSpec

    cls = Registry().optimizers["lsq"]
    job = Job(JobSpec(runs=1, progress=False, report=False, isolation="none"), "ride_quarter",
              RideQuarterProblem, config, "lsq", cls,
              cls.Params(ps=10, iterations=40, budget=410), 410)
    folder = tmp_path / "fit"
    run_job(job, folder)
    build_report([folder], folder / "report", short=True)
    return folder


def _fit_stated(tmp_path: Path, record: Path) -> tuple[Path, dict, dict[str, float]]:
    """:func:`_fit` of the logger's ``record`` with the tyre stated and a box that holds the
    spring: its folder, its record and the identified values by name."""
    config = RideQuarterConfig(reference=RecordFileConfig(str(record), columns=LOGGER),
                               known={"kt": KT}, bounds={"ks": [15000.0, 45000.0]})
    folder = _fit(tmp_path, config)
    rec = json.loads(next((folder / "records").glob("run-*.json")).read_text())
    return folder, rec, dict(zip(rec["parameters"]["names"], rec["result"]["x_best"],
                                 strict=True))


def test_a_richer_cars_record_with_the_tyre_stated_gives_ms_mu_ks_within_2_percent(
        tmp_path, logger_record):
    """Issue 41's case: the record fits equally well at any common scale of (ms, mu, ks, cs,
    kt), so with the parameter set's tyre (163,250 N/m) every estimate came out about 22 %
    low; with the tyre stated (210,000 N/m) and a box for ks that holds this car's spring
    (29,500 N/m lies above the set's box, 23,737.5), ms, mu and ks are within 2 %, and the
    first screen names the tyre used and the input."""
    folder, rec, x = _fit_stated(tmp_path, logger_record)
    for name in ("ms", "mu", "ks"):
        assert x[name] == pytest.approx(TRUTH[name], rel=0.02), (name, x[name])
    info = rec["problem"]["info"]
    assert {"name": "kt", "value": KT, "unit": "N/m", "source":
            "set by you (problem.known.kt)", "what": "tyre stiffness"} in info["known"]
    assert info["input"] == "the record's h (column road)"
    box = {b["name"]: b for b in info["box"]}
    assert (box["ks"]["lower"], box["ks"]["upper"]) == (15000.0, 45000.0)
    screen = (folder / "report" / "report.md").read_text()
    assert "kt = 210000 N/m (tyre stiffness)" in screen and "problem.known.kt" in screen
    assert "ks [15000, 45000] N/m" in screen and "Input used: the record's h" in screen
    overview = (folder / "report" / "index.html").read_text()
    assert "kt = 210000 N/m (tyre stiffness)" in overview  # the HTML overview too
    # the same fit's diagnostics: the richer car's residuals are flagged in one line, and the
    # interval that survives correlated residuals (prewhitened HAC) is at least 3x the
    # white-noise one (lag-1 0.87: an AR(1) of it would give sqrt(1.87 / 0.13) = 3.8x)
    diag = json.loads((folder / "diagnostics.json").read_text())
    assert diag["status"] == "ok" and not diag["explained"]
    flat = " ".join(screen.split())  # report.md wraps its paragraphs
    assert flat.count("The residuals are correlated") == 1
    assert "the model misses dynamics the record holds; the white-noise intervals are too " \
           "narrow" in flat
    iv = diag["intervals"]
    white, robust = np.asarray(iv["se"], float), np.asarray(iv["robust"]["se"], float)
    assert np.all(robust >= 3 * white), (robust / white, iv["robust"])


@pytest.mark.slow
@pytest.mark.parametrize("road", range(1, 9))
def test_the_design_holds_on_eight_roads(tmp_path, road):
    """The record design of :data:`DURATION_S`, not one lucky road: on eight roads (and
    noises) ms, mu and ks lie within 2 % and every robust interval is >= 3x the white one."""
    folder, _, x = _fit_stated(tmp_path, write_logger_record(tmp_path, road, road + 100))
    for name in ("ms", "mu", "ks"):
        assert x[name] == pytest.approx(TRUTH[name], rel=0.02), (name, x[name])
    iv = json.loads((folder / "diagnostics.json").read_text())["intervals"]
    ratio = np.asarray(iv["robust"]["se"], float) / np.asarray(iv["se"], float)
    assert np.all(ratio >= 3), ratio


def test_the_parameter_sets_tyre_scales_every_estimate(logger_record):
    """The same record with the parameter set's tyre: the same fit (the objective is equal
    to 1e-6) at every estimate times 163,250 / 210,000: what a hidden known quantity does,
    and why it is stated."""
    from scipy.optimize import least_squares

    def fit(**keys):
        p = RideQuarterProblem(RideQuarterConfig(
            reference=RecordFileConfig(str(logger_record), columns=LOGGER), **keys))
        b = p.bounds
        r = least_squares(lambda x: p.residuals(x[None])[0], (b.lower + b.upper) / 2,
                          bounds=(b.lower, b.upper), x_scale=p.nominal)
        return r.x, p.evaluate(r.x[None])[0]

    stated, f_stated = fit(known={"kt": KT}, bounds={"ks": [15000.0, 45000.0]})
    hidden, f_hidden = fit()
    assert f_hidden == pytest.approx(f_stated, rel=1e-6)
    np.testing.assert_allclose(hidden, stated * 163250.0 / KT, rtol=1e-3)


# --- the keys ----------------------------------------------------------------------------------
@pytest.mark.parametrize(("keys", "fragment"), [
    ({"known": {"kx": 1}}, "problem.known.kx=1 is not allowed: one of ms, mu, ks, cs, kt, ct"),
    ({"known": {"kt": -5}}, "problem.known.kt=-5 is not allowed: a finite value > 0 (N/m)"),
    ({"known": {"kt": "free"}}, "freeing it leaves this problem unidentifiable by scaling "
     "(every mass, stiffness and damping times one factor gives the same record); state one "
     "of ms, mu, ks, cs with problem.known.<name>=value first"),
    ({"known": {"ct": "free", "ms": 250}}, "give problem.bounds.ct=[lo,hi]"),
    ({"known": {"ms": 1, "mu": 1, "ks": 1, "cs": 1}}, "at least one quantity left to identify"),
    ({"bounds": {"kt": [1, 2]}}, "problem.bounds.kt=[1, 2] is not allowed: the name of an "
     "identified quantity, one of ms, mu, ks, cs"),
    ({"bounds": {"ks": [2, 1]}}, "[lo, hi] with 0 < lo < hi"),
    ({"bounds": {"ks": [0, 1]}}, "[lo, hi] with 0 < lo < hi"),
    ({"bounds": {"ks": [1, math.inf]}}, "[lo, hi] with 0 < lo < hi, finite"),
    ({"bounds": {"ks": [1, 2, 3]}}, "[lo, hi] with 0 < lo < hi"),
    ({"bounds": {"ks": "wide"}}, "[lo, hi] with 0 < lo < hi"),
])
def test_bad_known_and_bounds_keys_are_refused_naming_the_allowed(keys, fragment):
    with pytest.raises(ConfigError) as err:
        RideQuarterConfig(**keys)
    assert fragment in str(err.value) and "\n" not in str(err.value)


def test_a_fixed_parameter_leaves_the_search_and_a_freed_tyre_joins_it():
    """``known.ms=300`` fixes ms (the search is mu, ks, cs, kt), ``known.kt=free`` identifies
    the tyre: the model with the truth's values in the new layout gives the same channels as
    the model with them in the old one."""
    plain = RideQuarterProblem(RideQuarterConfig(truth="set", noise_level=0.0))
    x = plain.x_true  # the parameter set: ms 250, mu 37.5, ks 15825, cs 1500 (kt 163250)
    moved = RideQuarterProblem(RideQuarterConfig(truth="set", noise_level=0.0,
                                                 known={"ms": 250.0, "kt": "free"}))
    assert moved.bounds.names == ("mu", "ks", "cs", "kt")
    np.testing.assert_allclose(moved.x_true, [37.5, 15825.0, 1500.0, 163250.0])
    np.testing.assert_allclose(moved.bounds.lower, 0.5 * moved.x_true)
    X = np.stack([moved.x_true, moved.x_true * [1.1, 0.9, 1.2, 0.8]])
    full = np.stack([x, [250.0, *(x[1:] * [1.1, 0.9, 1.2])]])
    ours = moved.responses(X)
    # the plain model with the second row's tyre at 0.8 x 163250: made with its own known
    second = RideQuarterProblem(RideQuarterConfig(truth="set", noise_level=0.0,
                                                  known={"kt": 0.8 * 163250.0}))
    np.testing.assert_allclose(ours[0], plain.responses(full[:1])[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ours[1], second.responses(full[1:])[0], rtol=1e-12, atol=1e-12)
    assert moved.evaluate(moved.x_true[None])[0] == pytest.approx(
        plain.evaluate(x[None])[0], rel=1e-9)  # the same record, fitted the same
    assert {k["name"] for k in moved.describe()["known"]} == {"ms", "ct"}
    import copy
    import pickle

    for again in (pickle.loads(pickle.dumps(moved)), copy.deepcopy(moved)):
        np.testing.assert_array_equal(again.responses(X), ours)


def test_the_default_problem_is_unchanged_by_the_new_keys():
    """No key given: the same model object, box and record as before (archives stay valid),
    and a config with the keys still hashes (problems are cached by config)."""
    a = RideQuarterProblem(RideQuarterConfig())
    assert type(a.model).__name__ == "QuarterCar"
    np.testing.assert_array_equal(a.bounds.lower, 0.5 * a.nominal)
    from vpid_bench.params import settings_of

    assert "known" not in settings_of(RideQuarterConfig())
    assert settings_of(RideQuarterConfig(known={"kt": KT}))["known"] == {"kt": KT}
    hash(RideQuarterConfig(known={"kt": KT}, bounds={"ks": [1.0, 2.0]}))


def test_the_command_line_sets_known_and_bounds_without_a_plus(in_tmp, capsys):
    """``problem.known.kt=...`` and ``problem.bounds.ks=[...]`` are plain overrides (the
    mappings are open to new keys); a bad name is one ``error:`` line listing the allowed."""
    jobs = _plan(["problem=ride_quarter", "problem.known.kt=210000",
                    "problem.bounds.ks=[15000,45000]"]).jobs
    assert jobs[0].problem_config.known == {"kt": 210000}
    assert jobs[0].problem_config.bounds == {"ks": (15000, 45000)}
    code, err = _main(["problem=ride_quarter", "problem.known.tyre=2", "runs=1"],
                                capsys)
    assert code == 2 and err == ("error: problem.known.tyre=2 is not allowed: one of ms, mu, ks, "
                                 "cs, kt, ct (the quantities of this problem)\n")
    code, err = _main(["problem.known.kt1=170000", "problem.bounds.m=[400,700]",
                                 "problem.bounds.q=[1,2]", "runs=1"], capsys)
    assert code == 2 and err.startswith("error: problem.bounds.q=[1, 2] is not allowed: known "
                                        "keys are I, a1, c1, c2, k1, k2, lower_factor, m")


def test_the_paper_problem_takes_its_stated_quantities_and_boxes_by_name():
    """``problem=vehicle``: ``known.kt1`` sets ``vehicle.kt1``; a parameter's own box
    replaces its row of the factor box; the record lists both with their sources."""
    from vehicle_helpers import make

    p = make(**{"known": {"kt1": 170000.0}, "bounds.m": (400.0, 700.0), "noise.level": 0.0})
    assert p.config.vehicle.kt1 == 170000.0 and p.known.kt1 == 170000.0
    assert (p.bounds.lower[0], p.bounds.upper[0]) == (400.0, 700.0)
    assert p.bounds.lower[1] == 0.5 * 651.0
    info = p.describe()
    kt1 = next(k for k in info["known"] if k["name"] == "kt1")
    assert kt1["source"] == "set by you (problem.known.kt1)" and kt1["value"] == 170000.0
    assert info["box"][0]["source"] == "set by you (problem.bounds.m)"
    with pytest.raises(ConfigError, match=r"problem.known.m=500 is not allowed: one of L, kt1, "
                       r"kt2, V, h, w"):
        make(**{"known": {"m": 500}})


# --- strict records with a column mapping -----------------------------------------------------
def test_columns_map_units_and_ignore(tmp_path, logger_record):
    """A mapping's unit is used where the header states none, and must agree where it
    does; ``ignore`` lets a column stay unused; an unused column is refused naming it; a
    mapping from a name the problem does not have is refused naming the allowed ones."""
    text = logger_record.read_text().splitlines()
    bare = tmp_path / "bare.csv"
    bare.write_text("\n".join(["time,body_acc,wheel_acc,road,temperature",
                               *(r + ",21.5" for r in text[1:])]) + "\n")
    units = {"t": "time [s]", "zsdd": "body_acc", "zudd": "wheel_acc [g]", "h": "road [mm]"}
    ref = RecordFileConfig(str(bare), columns=units, ignore=("temperature",))
    p = RideQuarterProblem(RideQuarterConfig(reference=ref))
    q = RideQuarterProblem(RideQuarterConfig(reference=RecordFileConfig(str(logger_record),
                                                                        columns=LOGGER)))
    np.testing.assert_allclose(p.measured, q.measured, rtol=1e-15)
    np.testing.assert_allclose(p.u, q.u, rtol=1e-15)
    with pytest.raises(ConfigError, match="column 'temperature' is not used"):
        RideQuarterConfig(reference=RecordFileConfig(str(bare), columns=units))
    with pytest.raises(ConfigError, match=r"problem.reference.columns.h='road \[m\]' is not "
                       r"allowed: the unit the header states for road \(\[mm\]\) or none"):
        RideQuarterConfig(reference=RecordFileConfig(str(logger_record),
                                                     columns={**LOGGER, "h": "road [m]"}))
    with pytest.raises(ConfigError, match=r"problem.reference.columns.road='h' is not allowed: "
                       r"a mapping from the problem's names, one of t, zsdd, zudd, h"):
        RideQuarterConfig(reference=RecordFileConfig(str(logger_record), columns={"road": "h"}))
    with pytest.raises(ConfigError, match="problem.reference.columns='road' is not allowed"):
        RecordFileConfig(str(logger_record), columns="road")
    with pytest.raises(ConfigError, match="problem.reference.columns.h=5 is not allowed: a "
                       "column name"):
        RideQuarterConfig(reference=RecordFileConfig(str(logger_record), columns={"h": 5}))
    with pytest.raises(ConfigError, match="problem.reference.columns.h='street' is not allowed: "
                       "a column of my_car.csv; found columns time, body_acc, wheel_acc, road"):
        RideQuarterConfig(reference=RecordFileConfig(str(logger_record),
                                                     columns={**LOGGER, "h": "street"}))


def test_the_configured_input_is_used_only_when_said(tmp_path, logger_record):
    """A record without the road: refused, unless ``input=config`` says the configured road
    is meant (and the info line says so); a random road cannot be configured; with
    ``input=config`` a road column is unused unless ignored."""
    text = logger_record.read_text().splitlines()
    no_road = tmp_path / "no_road.csv"
    no_road.write_text("\n".join(",".join(r.split(",")[:3]) for r in text) + "\n")
    cols = {k: v for k, v in LOGGER.items() if k != "h"}
    with pytest.raises(ConfigError, match="column h is missing"):
        RideQuarterConfig(reference=RecordFileConfig(str(no_road), columns=cols))
    said = RecordFileConfig(str(no_road), columns=cols, input="config")
    p = RideQuarterProblem(RideQuarterConfig(reference=said))
    assert p.describe()["input"].startswith("the configured input (problem.reference.input="
                                            "config: road=hump")
    with pytest.raises(ConfigError, match="problem.reference.input='config' is not allowed: "
                       "record here: road=iso8608 is a random road"):
        RideQuarterConfig(road="iso8608", reference=said)
    with pytest.raises(ConfigError, match="column 'road' is not used"):
        RideQuarterConfig(reference=RecordFileConfig(str(logger_record), columns=cols,
                                                     input="config"))
    with pytest.raises(ConfigError, match="problem.reference.input='both' is not allowed"):
        RideQuarterConfig(reference=RecordFileConfig(str(logger_record), input="both"))


def test_the_paper_problem_reads_a_loggers_names_and_its_written_reference(tmp_path):
    """``problem=vehicle``: its channels from a logger's columns by the mapping, a column
    listed in ``ignore`` left unread, another unused one refused; the bump is its input (no
    input column, no ``input`` key); a written reference.csv keeps its clean columns."""
    from vehicle_helpers import make

    src = make(**{"noise.level": 0.0})
    y = src.responses(src._x_true[None])[0]
    path = tmp_path / "paper.csv"
    path.write_text("time,front [g],rear,speed\n" + "".join(
        f"{float(12.3 + t)!r},{float(a / G)!r},{float(b)!r},20.0\n"
        for t, a, b in zip(src.t, *y, strict=True)))
    cols = {"t": "time", "z1dd": "front", "z2dd": "rear"}
    p = make(**{"reference.file": str(path), "reference.columns": cols,
                "reference.ignore": ("speed",)})
    np.testing.assert_allclose(p.reference, y, rtol=1e-12)
    assert p.evaluate(src._x_true[None])[0] < 1e-9
    with pytest.raises(ConfigError, match="column 'speed' is not used"):
        make(**{"reference.file": str(path), "reference.columns": cols})
    written = src.write_artifacts(tmp_path)[0]
    assert "z1dd_clean" in written.read_text().splitlines()[0]
    make(**{"reference.file": str(written)})  # read back as it is
