"""Issue 13, cases 9-16: bad input is refused before any work, in one line naming its key,
with exit status 2 (in-process ``vpid-bench``: the pre-flight, no job runs)."""

from __future__ import annotations

import numpy as np
import pytest
from extras import needs
from hostile_helpers import TINY, main_in_process, plan_of

from vpid_bench.api import ConfigError

#: The joblib launcher comes with an extra (installed by ``make install``); without it the
#: cases that name it are skipped, not failed.
NEEDS_JOBLIB = needs("hydra_plugins.hydra_joblib_launcher", "joblib")


FUNCTIONS = ["problem=functions", "runs=1", "problem.iterations=2", "progress=false",
             "report=false"]


def _grid():
    from vpid_vehicle.config import VehicleConfig, window
    from vpid_vehicle.road import time_grid

    config = VehicleConfig()
    return [float(t) for t in time_grid(window(config), config.dt)]


def _csv(path, rows_of, encoding="utf-8", header="t,z1dd,z2dd", rows=None):
    grid = _grid()[:rows] if rows else _grid()
    path.write_text(header + "\n" + "".join(rows_of(i, t) for i, t in enumerate(grid)),
                    encoding=encoding)
    return path


@pytest.fixture
def csv_files(tmp_path):
    """Reference files: (name -> path) for the CSV cases of 13 and 14."""
    out = {
        "zero": _csv(tmp_path / "zero.csv", lambda i, t: f"{t!r},0,0\n"),
        "nan": _csv(tmp_path / "nan.csv", lambda i, t: f"{t!r},{'nan' if i == 7 else 1},1\n"),
        "inf": _csv(tmp_path / "inf.csv", lambda i, t: f"{t!r},1,{'-inf' if i == 9 else 1}\n"),
        "backwards": _csv(tmp_path / "backwards.csv",
                          lambda i, t: f"{t - 0.01 if i == 5 else t!r},1,1\n"),
        "repeat": _csv(tmp_path / "repeat.csv", lambda i, t: f"{0.0 if i == 1 else t!r},1,1\n"),
        "few": _csv(tmp_path / "few.csv", lambda i, t: f"{t!r},1,1\n", rows=5),
        "long": _csv(tmp_path / "long.csv", lambda i, t: f"{1e4 * t!r},1,1\n"),
        "nocol": _csv(tmp_path / "nocol.csv", lambda i, t: f"{t!r},1\n", header="t,z1dd"),
        "unit": _csv(tmp_path / "unit.csv", lambda i, t: f"{t!r},1,1\n",
                     header="t [s],z1dd [km/h],z2dd"),
        "strange": _csv(tmp_path / "strange.csv", lambda i, t: f"{t!r},1,1\n",
                        header="t [fortnight],z1dd,z2dd"),
        "twice": _csv(tmp_path / "twice.csv", lambda i, t: f"{t!r},1,1,1\n",
                      header="t,z1dd,z2dd,z1dd [g]"),
        "text": _csv(tmp_path / "text.csv", lambda i, t: f"{t!r},{'abc' if i == 2 else 1},1\n"),
        "bom": _csv(tmp_path / "bom.csv", lambda i, t: f"{t!r},{np.sin(t)},{np.cos(t)}\n",
                    encoding="utf-8-sig"),
    }
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n\x00\xff\xfe" * 20)
    out["binary"] = binary
    return out


# (issue case, command line, the start of the one error line)
REFUSED = [
    ("9", ["-m", "problem.noise.level=interval(0,1)"],
     "error: problem.noise.level='interval(0,1)' is not allowed: a list of values"),
    ("9", ["-m", "runs=range(0,1,0)"], "error: runs='range(0,1,0)' is not allowed: range("),
    ("9", ["hydra/launcher=${oc.decode:'1'}"],
     "error: hydra/launcher=\"${oc.decode:'1'}\" is not allowed: a config name"),
    ("10", ["optimizer=de1,de4"], "error: optimizer='de1,de4' is not allowed: one value here"),
    ("24", ["run_timeout_s=1e10"], "error: run_timeout_s=10000000000.0 is not allowed: a "
     "positive number of seconds up to 604800"),
    ("24", ["isolation=threads"], "error: isolation='threads' is not allowed: auto | process "
     "| none"),
    ("24", ["workers=0"], "error: workers=0 is not allowed: an integer from 1 to 1024"),
    ("10", ["~problem"], "error: ~problem='' is not allowed: a problem for every job"),
    ("10", ["~optimizer.elite_count"],
     "error: optimizer.elite_count='~' is not allowed: a key that exists"),
    ("10", ["hydra/launcher=nosuch"], "error: hydra/launcher='nosuch' is not allowed: one of "),
    ("10", ["hydra.launcher.n_jobs=abc"], "error: hydra.launcher.n_jobs="),
    pytest.param("10", ["hydra/launcher=joblib", "hydra.launcher.n_jobs=abc"],
                 "error: hydra.launcher.n_jobs='abc' is not allowed", marks=NEEDS_JOBLIB),
    ("10", ["runs=range(0,1000000)"], "error: runs='range(0,1000000)' is not allowed: one "
     "value here"),
    ("10", ["-m", "runs=range(0,1000000)"], "error: runs='range(0,1000000)' is not allowed: a "
     "sweep of at most 10000 values"),
    ("11", ["problem.noise.level=-1"], "error: problem.noise.level=-1.0 is not allowed: a noise"),
    ("11", ["optimizer=de1", "optimizer.bounds=foo"], "error: optimizer.bounds='foo' is not "
     "allowed: one of 'reinit', 'clip', 'reflect', 'midpoint'"),
    ("11", ["optimizer=de2", "problem.ps=4"], "error: problem.ps=4 is not allowed: at least 5"),
    ("11", ["runs=2.5"], "error: runs=2.5 is not allowed: an integer"),
    ("11", ["problem.ps=2.5"], "error: problem.ps=2.5 is not allowed: an integer"),
    ("12", ["problem.record.extra=1e6"], "error: problem.record.extra=1000000.0 is not allowed: "
     "a record of at most 1000000 samples"),
    ("12", ["problem.reference.dt=1e-11"], "error: problem.reference.dt=1e-11 is not allowed: a "
     "reference of at most 1000000 steps"),
    ("12", ["problem.bump.w=100000"], "error: problem.bump.w=100000.0 is not allowed: a record "
     "of at most 1000000 samples"),
    ("12", ["problem.dt=1e-9"], "error: problem.dt=1e-09 is not allowed: a record of at most"),
    ("12", ["problem.bump.V=1e-5"], "error: problem.bump.V=1e-05 is not allowed: a record of"),
    ("12", ["problem.record.extra=50", "problem.ps=10000", "optimizer=random"],
     "error: problem.ps=10000 is not allowed: a job of at most about 2 GiB"),
    ("12", ["optimizer=de1", "problem.ps=9000"], "error: problem.ps=9000 is not allowed: at most "
     "8192 for de1"),
    ("12", ["problem.ps=100000"], "error: problem.ps=100000 is not allowed: an integer from 1 to"),
    ("13", ["optimizer=de6", "optimizer.K=inf"], "error: optimizer.K=inf is not allowed: a "
     "finite number"),
    ("13", ["optimizer=de8", "optimizer.R_max=inf"], "error: optimizer.R_max=inf is not allowed"),
    ("13", ["optimizer=de6", "optimizer.F_min=-inf"], "error: optimizer.F_min=-inf is not "
     "allowed: a finite number"),
    ("13", ["optimizer=de7", "optimizer.R_min=-inf"], "error: optimizer.R_min=-inf is not "
     "allowed: a finite number"),
    ("13", ["optimizer=jade", "optimizer.p=inf"], "error: optimizer.p=inf is not allowed"),
    ("13", ["problem.bump.h=1e308"], "error: problem.bump.h=1e+308 is not allowed: a bump "
     "height with 0 < |h| <= 1 m"),
    ("13", ["problem.bump.h=0"], "error: problem.bump.h=0.0 is not allowed: a bump height"),
    ("13", [*FUNCTIONS, "problem.half_width=1e308"], "error: problem.half_width=1e+308 is not "
     "allowed"),
    ("14", [*FUNCTIONS, "problem.half_width=inf"], "error: problem.half_width=inf is not "
     "allowed"),
    ("16", ["-m", "runs=range(20,10)"], "error: runs='range(20,10)' is not allowed: a sweep "
     "with at least one value"),
    ("16", ["-m", *TINY, "hydra.sweep.dir="], "error: hydra.sweep.dir='' is not allowed: a "
     "folder name"),
    ("16", [*TINY, "hydra.run.dir="], "error: hydra.run.dir='' is not allowed: a folder name"),
]


@pytest.mark.parametrize(("case", "argv", "line"), REFUSED,
                         ids=[f"{c}: {' '.join(a)}" for c, a, _ in
                              (getattr(case, "values", case) for case in REFUSED)])
def test_refused_in_one_line_before_any_work(case, argv, line, in_tmp, capsys):
    code, err = main_in_process(argv, capsys)
    assert code == 2, err
    assert err.startswith(line), err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not list(in_tmp.rglob("records")), "nothing may run"


# (case, file, the key's message fragment)
CSV_REFUSED = [
    ("13", "zero", "a record in which every measured channel moves (column z1dd is zero "
     "throughout"),
    ("14", "nan", "finite numbers; row 9 column z1dd is nan"),
    ("14", "inf", "finite numbers; row 11 column z2dd is -inf"),
    ("14", "binary", "a text CSV file in UTF-8"),
    ("31", "backwards", "a t column that increases from row to row; row 7 has t = -0.005 s "
     "after 0.004 s"),
    ("31", "repeat", "a t column that increases from row to row; row 3 has t = 0 s"),
    ("31", "few", "at least 10 rows of samples; found 5"),
    ("31", "long", "a record spanning at most 1000000 model steps"),
    ("31", "nocol", "a header with columns t, z1dd, z2dd (units optional, e.g. t [s]); column "
     "z2dd is missing; found columns t, z1dd"),
    ("31", "unit", "column z1dd in a unit of acceleration, one of g, m/s^2, m/s², mm/s^2 "
     "(found [km/h])"),
    ("31", "strange", "column t in a unit of time, one of ms, s (found [fortnight])"),
    ("31", "twice", "each column once; column 'z1dd' appears twice"),
    ("31", "text", "a number in column z1dd of every row; row 4 has none"),
]


@pytest.mark.parametrize(("case", "name", "fragment"), CSV_REFUSED,
                         ids=[f"{c}: {n}" for c, n, _ in CSV_REFUSED])
def test_bad_reference_files_are_refused_by_the_preflight(case, name, fragment, csv_files,
                                                          in_tmp, capsys):
    code, err = main_in_process([f"problem.reference.file={csv_files[name]}", "runs=1"], capsys)
    assert code == 2
    assert err.startswith(f"error: problem.reference.file='{csv_files[name]}' is not allowed: ")
    assert fragment in err and err.count("\n") == 1


def _ride_csv(path, header, row):
    path.write_text(header + "\n" + "".join(row(k, 0.002 * k) for k in range(50)))
    return path


RIDE_REFUSED = [
    ("iso road without its columns", ["problem=ride_full", "problem.road=iso8608"],
     "t,bFLdd,bFRdd,bRLdd,bRRdd", lambda k, t: f"{t},1,1,1,1\n",
     "input columns h_FL, h_FR, h_RL, h_RR (road=iso8608 is a random road, which a record "
     "must carry: the road height under each wheel; or set problem.road to hump, bump or "
     "step); column h_FL is missing"),
    ("half the road columns", ["problem=ride_half"], "t,z1dd,z2dd,h1",
     lambda k, t: f"{t},1,1,0\n",
     "input columns h1, h2 (the inputs the model is driven by: map a column with "
     "problem.reference.columns={h2:<column>}, or fit the configured input with "
     "problem.reference.input=config); column h2 is missing"),
    ("a channel of the sensor set missing", ["problem=ride_quarter"], "t,zsdd",
     lambda k, t: f"{t},1\n", "column zudd is missing"),
    ("t in ms read as s", ["problem=ride_quarter", "problem.reference.input=config"],
     "t,zsdd,zudd",
     lambda k, t: f"{1e4 * t},1,1\n", "a record spanning at most 200000 model steps (this one: "
     "t = 0 ... 980 s, 980 s at dt = 0.001 s is 9.8e+05 steps; a time in ms is written t [ms])"),
    ("steer without speed", ["problem=lateral"], "t,r,ay,delta [deg]",
     lambda k, t: f"{t},1,1,1\n", "input columns delta, vx (the inputs the model is driven by"),
    ("a speed that varies", ["problem=lateral_mf"], "t,r,ay,delta,vx [km/h]",
     lambda k, t: f"{t},1,1,0.01,{72 + (10 if k == 30 else 0)}\n",
     "a column vx (m/s) > 0 held within 2 % of its mean"),
]


@pytest.mark.parametrize(("what", "argv", "header", "row", "fragment"), RIDE_REFUSED,
                         ids=[c[0] for c in RIDE_REFUSED])
def test_bad_records_of_the_ride_and_lateral_problems_are_refused_by_the_preflight(
        what, argv, header, row, fragment, in_tmp, capsys, tmp_path):
    path = _ride_csv(tmp_path / "r.csv", header, row)
    code, err = main_in_process([*argv, f"problem.reference.file={path}", "runs=1"], capsys)
    assert code == 2, err
    assert err.startswith(f"error: problem.reference.file='{path}' is not allowed: "), err
    assert fragment in err and err.count("\n") == 1


def test_a_reference_file_is_never_quoted(in_tmp, capsys, tmp_path):
    """Case 2's rule for messages: a file that is not a reference is named, not quoted."""
    secret = tmp_path / "passwd"
    secret.write_text("root:x:0:0:root:/root:/bin/bash\nuser:x:1000:1000::/home/user:/bin/sh\n")
    code, err = main_in_process([f"problem.reference.file={secret}", "runs=1"], capsys)
    assert code == 2 and "root:x" not in err and "found no such header row" in err


def test_a_utf8_bom_is_accepted(csv_files):
    planned = plan_of([f"problem.reference.file={csv_files['bom']}"])
    assert planned.jobs[0].problem_config.reference.file == str(csv_files["bom"])
    from vpid_vehicle.problem import VehicleProblem

    problem = VehicleProblem(planned.jobs[0].problem_config)
    t = np.asarray(_grid())
    np.testing.assert_allclose(problem.reference, [np.sin(t), np.cos(t)], rtol=1e-12)


def test_memory_estimate_is_in_the_cap_message():
    """Case 12: the estimate is samples x candidates x bytes (plus the set-up per step)."""
    from vpid_vehicle.config import (
        BYTES_PER_SAMPLE_CANDIDATE,
        BYTES_PER_STEP,
        RecordConfig,
        VehicleConfig,
    )

    with pytest.raises(ConfigError) as err:
        VehicleConfig(record=RecordConfig(extra=2000.0), ps=20)
    samples = (2000.0 + 2.666 / (20 / 3.6)) / 0.001 + 1
    expected = (2 * samples * BYTES_PER_STEP + samples * 20 * BYTES_PER_SAMPLE_CANDIDATE) / 2**30
    assert err.value.key == "problem.record.extra"
    assert f"about {expected:.3g} GiB" in err.value.allowed


def test_whole_number_floats_follow_one_rule():
    """Case 11: ``runs=2.0`` and ``problem.ps=1e3`` are both whole numbers: both accepted, as
    the same integers the job sees."""
    job = plan_of(["runs=2.0", "problem.ps=1e3", "optimizer=random"]).jobs[0]
    assert (job.spec.runs, job.problem_config.ps) == (2, 1000)
    assert isinstance(job.spec.runs, int) and isinstance(job.problem_config.ps, int)


def test_quoted_sweep_values_are_accepted():
    """Case 15: a quoted value in a sweep (a file name with spaces can be swept)."""
    planned = plan_of(["-m", "optimizer=de1", "optimizer.bounds='clip',reflect", *FUNCTIONS])
    assert [j.params.bounds for j in planned.jobs] == ["clip", "reflect"]
    assert len({d.name for d in planned.job_dirs}) == 2
