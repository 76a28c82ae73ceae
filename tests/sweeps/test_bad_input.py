"""Bad input: each is refused (or isolated) with one line naming the key, the bad value and
what is allowed; nothing already recorded is lost.

Three levels: the command line (pre-flight, before Hydra: exit 2), the job (a plugin's own
checks when the problem or optimizer is built, before any run), and the run (an optimizer or
problem that misbehaves: that run's record says ``failed``, the rest goes on).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from extras import limit, needs
from sweep_helpers import run_cli

from vpid_bench import Optimizer, OptimizerParams, hookimpl
from vpid_bench.api import ConfigError
from vpid_bench.experiment import run_from_config
from vpid_bench.plugins import Registry
from vpid_bench.store import records as rec

#: The joblib launcher comes with an extra (installed by ``make install``); without it the
#: cases that name it are skipped, not failed.
NEEDS_JOBLIB = needs("hydra_plugins.hydra_joblib_launcher", "joblib")


FUNCTIONS = ["problem=functions", "optimizer=random", "progress=false", "report=false"]

# (command line, the start of the one error line)
PREFLIGHT = [
    (["optimizer=nosuch"], "error: optimizer='nosuch' is not allowed: one of "),
    (["problem=nosuch"], "error: problem='nosuch' is not allowed: one of "),
    (["-m", "optimizer=random,nosuch"], "error: optimizer='nosuch' is not allowed: one of"),
    (["-m", "optimizer=glob(zzz*)"], "error: optimizer='glob(zzz*)' is not allowed: a pattern"),
    (["optimizer=de1", "optimizer.FF=1"],
     "error: optimizer.FF=1 is not allowed: optimizer 'de1' has no such key; keys under "
     "optimizer are CR, F,"),
    (["problem=functions", "problem.bar.x=1"],
     "error: problem.bar.x=1 is not allowed: problem 'functions' has no such key"),
    (["problem.noise.levle=0.1"], "error: problem.noise.levle=0.1 is not allowed: problem "
     "'vehicle' has no such key; keys under problem.noise are level, model, per_run, seed"),
    (["foo=1"], "error: foo=1 is not allowed: known top-level keys are problem, optimizer"),
    (["+foo=1"], "error: foo=1 is not allowed: known top-level keys are"),
    (["runs=0"], "error: runs=0 is not allowed: an integer from 1 to 10000"),
    (["runs=abc"], "error: runs='abc' is not allowed: an integer"),
    (["seed=-1"], "error: seed=-1 is not allowed: an integer >= 0"),
    (["seed=1.5"], "error: seed=1.5 is not allowed: an integer"),
    (["-m", "seed=0,-3"], "error: seed=-3 is not allowed: an integer >= 0"),
    (["budget=0"], "error: budget=0 is not allowed: an integer from 1 to 1000000000 or null"),
    (["resume=maybe"], "error: resume='maybe' is not allowed: true or false"),
    (["problem.iterations=0"],
     "error: problem.iterations=0 is not allowed: an integer from 1 to 1000000"),
    (["problem.ps=0"], "error: problem.ps=0 is not allowed: an integer from 1 to 10000"),
    (["optimizer=de1", "optimizer.ps=-2"], "error: optimizer.ps=-2 is not allowed: not "
     "settable on the optimizer: the job fills it in, set problem.ps"),
    (["problem.noise.level=abc"],
     "error: problem.noise.level='abc' is not allowed: a real number"),
    (["problem.noise.level=nan"], "error: problem.noise.level=nan is not allowed: a real number"),
    (["problem.dt=fast"], "error: problem.dt='fast' is not allowed: a real number"),
    (["problem.name=x"], "error: problem.name='x' is not allowed: choose the problem with"),
    (["runs=[1"], "error: override='runs=[1' is not allowed: key=value"),
    (["optimizer=de1,de4"], "error: optimizer='de1,de4' is not allowed: one value here; to "
     "run every value, start a sweep with -m"),
    (["-m", "runs=range(20,10)"], "error: runs='range(20,10)' is not allowed: a sweep with at "
     "least one value"),
    (["-m", "runs=range(0,1,0)"], "error: runs='range(0,1,0)' is not allowed: range(start, "
     "stop[, step]) with a step that is not 0"),
    (["-m", "problem.noise.level=interval(0,1)"], "error: problem.noise.level='interval(0,1)' "
     "is not allowed: a list of values"),
    (["-m", "seed=range(0,100000)"], "error: seed='range(0,100000)' is not allowed: a sweep of "
     "at most 10000 values"),
    (["~problem"], "error: ~problem='' is not allowed: a problem for every job"),
    pytest.param(["hydra/launcher=nosuch"], "error: hydra/launcher='nosuch' is not allowed: one "
                 "of basic, joblib", marks=NEEDS_JOBLIB),
    pytest.param(["hydra/launcher=joblib", "hydra.launcher.n_jobs=abc"],
                 "error: hydra.launcher.n_jobs='abc' is not allowed: Value 'abc' of type 'str' "
                 "could not be converted to Integer", marks=NEEDS_JOBLIB),
    (["hydra/launcher=${oc.decode:'1'}"], "error: hydra/launcher=\"${oc.decode:'1'}\" is not "
     "allowed: a config name, not an interpolation"),
    (["-m", "optimizer=de1,de4", "--cfg", "job"], "error: --cfg='job' is not allowed: a single "
     "run's config"),
    (["-m", "hydra.sweep.dir="], "error: hydra.sweep.dir='' is not allowed: a folder name"),
    (["problem/x=1"], "error: problem/x='1' is not allowed: config groups are problem, "
     "optimizer and Hydra's"),
]


def _main_error(argv: list[str], capsys) -> tuple[int, str]:
    from vpid_bench.shell.main import main

    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    return exit_info.value.code, capsys.readouterr().err


@pytest.mark.parametrize(("argv", "line"), PREFLIGHT,
                         ids=[" ".join(getattr(c, "values", c)[0]) for c in PREFLIGHT])
def test_command_line_is_refused_in_one_line(argv, line, in_tmp, capsys):
    code, err = _main_error(argv, capsys)
    assert code == 2
    assert err.startswith(line), err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not (in_tmp / "outputs" / "runs").exists() or not any(
        (in_tmp / "outputs" / "runs").iterdir()
    )


def test_unwritable_output_folder_is_refused(in_tmp, capsys):
    (in_tmp / "afile").write_text("not a folder")
    code, err = _main_error([*FUNCTIONS, "hydra.run.dir=afile/run"], capsys)
    assert code == 2
    assert err.startswith("error: hydra.run.dir='afile/run' is not allowed: a directory you can")


def test_a_refused_command_loses_no_record(in_tmp, capsys):
    """A bad override aimed at an existing sweep folder stops before touching it."""
    sweep = in_tmp / "sweep"
    job = sweep / "job"
    path = rec.write_record(rec.record_path(job, 0, "abc"), {"schema": "x"})
    before = path.read_bytes()
    code, _ = _main_error(["-m", *FUNCTIONS, "runs=0", f"hydra.sweep.dir={sweep}"], capsys)
    assert code == 2
    assert path.read_bytes() == before and sorted(p.name for p in sweep.rglob("*")) == [
        "job", "records", path.name]


# ---- job level: the plugin's own checks, through run_from_config (before any run) ----

JOB_ERRORS = [
    (["problem=functions", "problem.function=nope"], "problem.function", "one of 'sphere'"),
    (["problem=functions", "problem.dim=1"], "problem.dim", "an integer from 2 to"),
    (["problem=functions", "problem.half_width=-1"], "problem.half_width", "a positive number"),
    (["problem.noise.level=-0.1"], "problem.noise.level", "a noise level >= 0"),
    (["problem.dt=0"], "problem.dt", "a time step > 0"),
    (["problem.dt=-0.001"], "problem.dt", "a time step > 0"),
    (["problem.vehicle.a1=3.0"], "problem.vehicle.a1", "a value in (0, L)"),
    (["problem.vehicle.a1=0"], "problem.vehicle.a1", "a value in (0, L)"),
    (["problem.bounds.lower_factor=1.6"], "problem.bounds.upper_factor", "a factor >"),
    (["optimizer=de2", "problem.ps=4"], "problem.ps", "at least 5 for de2"),  # best + 4 others
    (["optimizer=de5", "problem.ps=5"], "problem.ps", "at least 6 for de5"),  # 5 others
    (["optimizer=de1", "optimizer.CR=1.5"], "optimizer.CR", "a number in [0, 1]"),
]


@pytest.mark.parametrize(("overrides", "key", "allowed"), JOB_ERRORS,
                         ids=[" ".join(o) for o, _, _ in JOB_ERRORS])
def test_job_refuses_bad_values_before_any_run(overrides, key, allowed, compose_config,
                                               registry, tmp_path):
    cfg = compose_config([*overrides, "runs=2", "progress=false"])
    with pytest.raises(ConfigError) as err:
        run_from_config(cfg, tmp_path / "job", registry)
    assert err.value.key == key
    assert allowed in err.value.allowed
    assert not list(tmp_path.rglob("run-*.json"))


@pytest.mark.parametrize(("overrides", "key", "allowed"), JOB_ERRORS,
                         ids=[" ".join(o) for o, _, _ in JOB_ERRORS])
def test_preflight_refuses_a_plugins_own_check_in_any_sweep_point(overrides, key, allowed,
                                                                   registry):
    """The plugin's range check runs in the pre-flight for the second point of a sweep too,
    so no job of the sweep runs."""
    from vpid_bench.shell.argv import parse_command_line
    from vpid_bench.shell.preflight import plan

    good = {"problem.dt": "0.001", "problem.noise.level": "0.05", "problem.vehicle.a1": "1.468",
            "problem.ps": "20", "optimizer.CR": "0.9", "problem.dim": "3",
            "problem.half_width": "2", "problem.function": "sphere",
            "problem.bounds.lower_factor": "0.5"}
    swept = []
    for o in overrides:
        k, v = o.split("=", 1)
        swept.append(f"{k}={good[k]},{v}" if k in good else o)
    with pytest.raises(ConfigError) as err:
        plan(parse_command_line(["-m", *swept, "runs=2"]), registry)
    assert err.value.key == key and allowed in err.value.allowed


def test_the_issue_command_exits_2_before_any_job_folder(in_tmp, capsys):
    code, err = _main_error(["-m", "problem.dt=0.001,-1", "optimizer=de4", "runs=2",
                             "hydra.sweep.dir=sweep"], capsys)
    assert code == 2 and err.startswith("error: problem.dt=-1.0 is not allowed: a time step > 0")
    assert err.count("\n") == 1 and not (in_tmp / "sweep").exists()


@pytest.mark.parametrize(
    ("header", "allowed"),
    [("time,front,rear", "z1dd"), ("", "empty")],
    ids=["wrong columns", "empty file"],
)
def test_reference_csv_with_wrong_columns(header, allowed, compose_config, registry, tmp_path):
    csv = tmp_path / "ref.csv"
    csv.write_text(header + ("\n0,0,0\n" if header else ""))
    cfg = compose_config([f"problem.reference.file={csv}", "runs=1", "progress=false"])
    with pytest.raises(ConfigError) as err:
        run_from_config(cfg, tmp_path / "job", registry)
    assert err.value.key == "problem.reference.file"
    assert allowed in err.value.allowed


# ---- run level: crash isolation ----


@dataclasses.dataclass(frozen=True)
class _Params(OptimizerParams):
    fault: str = "none"  # "shape", "nan", "raise" in run 1, "raise_all"


class _Faulty(Optimizer):
    """Random search that breaks the contract in the way ``fault`` says (run 1 only)."""

    Params = _Params

    def ask(self) -> np.ndarray:
        fault = self.params.fault
        X = self.bounds.sample(self.rng, self.params.ps)
        if self.run_index == 1 and fault == "shape":
            return X[:, :1]
        if self.run_index == 1 and fault == "nan":
            X[0, 0] = np.nan
        if self.run_index == 1 and fault == "raise":
            raise RuntimeError("optimizer exploded")
        return X

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        pass

    @property
    def run_index(self) -> int:
        # The run loop gives run i the child stream i of the seed: recover i from it.
        return int(self.rng.bit_generator.seed_seq.spawn_key[0])


class _FaultyPlugin:
    @hookimpl
    def vpid_bench_register_optimizers(self, register):
        register("faulty", _Faulty)


@pytest.fixture(scope="module")
def faulty_registry(registry_of) -> Registry:
    import vpid_functions.plugin as functions

    return registry_of(("functions", functions), ("faulty", _FaultyPlugin()))


def _faulty_config(fault: str) -> dict:
    return {"problem": {"name": "functions", "ps": 5, "iterations": 3, "dim": 3},
            "optimizer": {"name": "faulty", "fault": fault},
            "seed": 0, "runs": 3, "progress": False}


@pytest.mark.parametrize(
    ("fault", "error_type", "message"),
    [("shape", "OptimizerContractError", "returned shape (5, 1), expected (n, 3)"),
     ("nan", "OptimizerContractError", "NaN"),
     ("raise", "RuntimeError", "optimizer exploded")],
)
def test_a_failing_run_is_recorded_and_the_job_goes_on(fault, error_type, message,
                                                       faulty_registry, tmp_path):
    summary = run_from_config(_faulty_config(fault), tmp_path, faulty_registry)
    assert summary.failed == [1] and summary.ran == 3
    records = [rec.read_record(p) for p in summary.record_paths]
    assert [r["status"] for r in records] == ["ok", "failed", "ok"]
    assert records[1]["error"]["type"] == error_type
    assert message in records[1]["error"]["message"]
    assert records[1]["result"] is None and records[2]["result"]["evaluations"] == 20


def test_a_problem_that_raises_fails_its_runs_not_the_command(faulty_registry, tmp_path,
                                                              monkeypatch):
    import vpid_functions.plugin as functions

    def boom(self, X):
        raise FloatingPointError("simulation diverged")

    monkeypatch.setattr(functions.FunctionsProblem, "evaluate", boom)
    summary = run_from_config(_faulty_config("none"), tmp_path, faulty_registry)
    assert summary.failed == [0, 1, 2]
    assert {rec.read_record(p)["error"]["message"] for p in summary.record_paths} == {
        "simulation diverged"}


# ---- the real command: exit status, one line, tracebacks only when asked ----


def test_cli_exit_status_and_single_lines(tmp_path, registry):
    bad = run_cli(["optimizer=nosuch"], tmp_path)
    assert bad.returncode == 2
    assert bad.stderr.splitlines() == [
        "error: optimizer='nosuch' is not allowed: one of "
        + ", ".join(sorted(Registry().optimizers))  # every installed optimizer, sorted
    ]
    refused = run_cli([*FUNCTIONS, "problem.dim=1", "runs=1"], tmp_path)
    assert refused.returncode == 2  # a plugin's range check: pre-flight, before any job
    assert refused.stderr == "error: problem.dim=1 is not allowed: an integer from 2 to 10000\n"
    job = run_cli(["problem.reference.file=missing.csv", "runs=1", "progress=false",
                   "report=false"], tmp_path)
    assert job.returncode == 2  # the vehicle's config reads the file: pre-flight, no job
    assert job.stderr.splitlines() == ["error: problem.reference.file='missing.csv' is not "
                                       "allowed: an existing CSV file (columns t, z1dd, z2dd)"]
    debug = run_cli(["optimizer=nosuch"], tmp_path, env={"VPID_BENCH_DEBUG": "1"})
    assert debug.returncode != 0 and "Traceback" in debug.stderr


def _fake_distribution(site: Path, name: str, entry_points: dict[str, str],
                       modules: dict[str, str]) -> None:
    """A minimal installed distribution (dist-info + modules) on a PYTHONPATH folder."""
    info = site / f"{name}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[vpid_bench]\n" + "".join(f"{k} = {v}\n" for k, v in entry_points.items()))
    for module, text in modules.items():
        (site / f"{module}.py").write_text(text)


DUPLICATE = """
from vpid_bench import hookimpl
from vpid_baselines.plugin import RandomSearch

@hookimpl
def vpid_bench_register_optimizers(register):
    register("random", RandomSearch)
"""


def test_broken_and_colliding_plugins(tmp_path):
    broken_site = tmp_path / "broken"
    _fake_distribution(broken_site, "vpid_broken", {"broken": "vpid_broken_mod"},
                       {"vpid_broken_mod": "raise ImportError('needs libfoo')\n"})
    env = {"PYTHONPATH": str(broken_site)}
    ok = run_cli([*FUNCTIONS, "runs=1"], tmp_path, env=env)
    assert ok.returncode == 0, ok.stderr
    assert ok.stderr.splitlines()[0] == (
        "warning: vpid-bench plugin 'broken' (vpid_broken 0.1) failed to import and was "
        "skipped: ImportError: needs libfoo")
    missing = run_cli([*FUNCTIONS, "optimizer=brokenopt"], tmp_path, env=env)
    assert missing.returncode == 2
    assert missing.stderr.splitlines()[-1].endswith(
        "(plugins that failed to load: broken: ImportError: needs libfoo)")

    dup_site = tmp_path / "dup"
    _fake_distribution(dup_site, "vpid_dup", {"dup": "vpid_dup_mod"}, {"vpid_dup_mod": DUPLICATE})
    dup = run_cli([*FUNCTIONS, "runs=1"], tmp_path, env={"PYTHONPATH": str(dup_site)})
    assert dup.returncode == 2
    lines = dup.stderr.splitlines()
    assert len(lines) == 1 and "'random' is registered twice" in lines[0]
    assert "'dup'" in lines[0] and "random" in lines[0]


def test_corrupt_job_status_and_record_are_reported_not_fatal(tmp_path):
    from vpid_bench.store.job_status import read_job_status

    (tmp_path / "job.json").write_text("{not json")
    assert read_job_status(tmp_path) is None
    bad = tmp_path / "records" / "run-000-x.json"
    bad.parent.mkdir()
    bad.write_text(json.dumps({"schema": rec.SCHEMA, "run_id": "x"}))
    with pytest.raises(rec.CorruptRecordError, match="incomplete run record, missing run_index"):
        rec.read_record(bad)


def test_the_report_names_a_corrupt_record_and_reports_the_rest(compose_config, registry,
                                                                tmp_path):
    """A torn record met by the report: one warning naming the file, the other runs reported,
    exit status 1 (report written, problems found)."""
    import subprocess
    import sys

    cfg = compose_config(["problem=functions", "optimizer=random", "runs=3", "progress=false",
                          "problem.iterations=3"])
    summary = run_from_config(cfg, tmp_path / "sweep" / "job", registry)
    torn = summary.record_paths[0]
    torn.write_text(torn.read_text()[:80])
    done = subprocess.run(
        [sys.executable, "-c", "from vpid_bench.report.cli import main; main()",
         str(tmp_path / "sweep"), "-o", str(tmp_path / "report")],
        capture_output=True, text=True, check=False, timeout=limit(120),
    )
    assert "Traceback" not in done.stderr
    warnings = [line for line in done.stderr.splitlines() if str(torn.name) in line]
    assert len(warnings) == 1 and "not a readable JSON run record" in warnings[0]
    assert "(2 run records)" in done.stdout + done.stderr
    assert done.returncode == 1
    assert (tmp_path / "report" / "report.md").is_file()
