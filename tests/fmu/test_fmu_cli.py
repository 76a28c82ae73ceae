"""problem=fmu through the command: its config composes from the command line (the open
mappings ``problem.known.<name>``, ``problem.bounds.<name>``, ``problem.reference.columns``
without Hydra's ``+``), and the issue's done-when run: ``vpid-bench -m problem=fmu
problem.fmu=<the test quarter car> optimizer=lsq,cmaes runs=5`` on a 500 Hz record the FMU made
recovers every parameter within its 95 % interval and records the known quantities."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("fmpy")

from vpid_fmu import example  # noqa: E402

from vpid_bench.spec import parse_job  # noqa: E402

TRUTH = {"ms": 280.0, "mu": 33.0, "ks": 17000.0, "cs": 1300.0}


@pytest.fixture(scope="module")
def record(example_fmu, tmp_path_factory):
    out = tmp_path_factory.mktemp("cli-record") / "record.csv"
    return example.write_record(example_fmu("fmi2"), out, TRUTH, duration=4.0)


def test_problem_fmu_composes_parses_and_builds(example_fmu, record, compose_config,
                                                registry, tmp_path):
    """The twin of tests/core/test_configs.py for problem=fmu, with every open mapping set
    from the command line."""
    renamed = tmp_path / "renamed.csv"
    renamed.write_text(record.read_text().replace("t,h,", "t,road,", 1))
    cfg = compose_config(["problem=fmu", f"problem.fmu={example_fmu('fmi2')}",
                          f"problem.reference.file={renamed}", "problem.reference.columns.h=road",
                          "problem.known.kt=170000", "problem.bounds.ms=[200,400]",
                          "optimizer=random"])
    job = parse_job(cfg, registry)
    problem = job.problem_cls(job.problem_config)
    assert problem.bounds.dim == 4 and problem.bounds.lower[0] == 200.0
    info = problem.describe()
    assert info["known"] == [{"name": "kt", "value": 170000.0, "unit": "N/m",
                              "source": "set by you (problem.known)"}]
    assert info["box"][0]["source"] == "set by you (problem.bounds)"
    assert "road" in info["input"]
    # the tyre freed: named in problem.parameters with a box from the command line
    cfg = compose_config(["problem=fmu", f"problem.fmu={example_fmu('fmi2')}",
                          f"problem.reference.file={record}", "problem.parameters=[ms,kt]",
                          "problem.bounds.kt=[1e5,3e5]", "problem.interface=me",
                          "optimizer=random"])
    job = parse_job(cfg, registry)
    problem = job.problem_cls(job.problem_config)
    assert problem.bounds.names == ("ms", "kt") and problem.kind == "me"
    assert [k["name"] for k in problem.describe()["known"]] == ["mu", "ks", "cs"]


@pytest.mark.slow
def test_lsq_and_cmaes_recover_every_parameter_within_its_interval(example_fmu, record,
                                                                    tmp_path):
    """The done-when run (about 2.5 min on 2 busy cores)."""
    done = subprocess.run(
        [sys.executable, "-c", "from vpid_bench.shell.main import main; main()", "-m",
         "problem=fmu", f"problem.fmu={example_fmu('fmi2')}",
         f"problem.reference.file={record}", "optimizer=lsq,cmaes", "runs=5",
         "progress=false", "hydra.sweep.dir=sweep"],
        cwd=tmp_path, capture_output=True, text=True, timeout=1200, check=False,
        env={**__import__("os").environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-3000:]
    records = [json.loads(p.read_text()) for p in (tmp_path / "sweep").glob(
        "*/records/run-*.json")]
    assert len(records) == 10 and all(r["status"] == "ok" for r in records)
    truth = np.array(list(TRUTH.values()))
    for r in records:
        iv = r["result"]["intervals"]
        lower, upper = np.array(iv["lower"], float), np.array(iv["upper"], float)
        assert np.all((lower <= truth) & (truth <= upper)), (r["optimizer"], iv)
        assert r["problem"]["info"]["known"] == [
            {"name": "kt", "source": "the FMU's start value", "unit": "N/m",
             "value": 163250.0}]
    report = (tmp_path / "sweep" / "report" / "report.md").read_text()
    assert "ms" in report and "95 % interval" in report
    flat = " ".join(report.split())  # report.md wraps its paragraphs
    # the known quantity and the fit diagnostics of the own-record work, on the FMU too
    assert "kt = 163250 N/m" in flat and "the FMU's start value" in flat
    assert "Fit diagnostics at the optimum" in flat and "whiteness test" in flat
