"""The Hydra callbacks write their outcome to disk; the command reads it from there."""

from __future__ import annotations

import json
import pickle
import subprocess
import sys

from omegaconf import OmegaConf

from vpid_bench.shell import callbacks
from vpid_bench.shell.callbacks import ReportCallback, job_dir_name


def _objective_job(folder, name, values):
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).parents[1] / "report"))
    from report_synth import objective_job

    objective_job(folder, name, 20, values)


def _status(folder):
    return json.loads((folder / "report" / "status.json").read_text())


def test_report_callback_writes_its_outcome_and_honours_report_false(tmp_path, monkeypatch,
                                                                     capsys):
    monkeypatch.setenv("VPID_BENCH_INVOCATION", "inv-1")
    sweep = tmp_path / "sweep"
    _objective_job(sweep, "a", [1.0, 2.0])
    _objective_job(sweep, "b", [3.0, 4.0])
    cb = ReportCallback()
    cb.on_multirun_end(OmegaConf.create({"report": False, "hydra": {"sweep": {"dir": str(sweep)}}}))
    assert not (sweep / "report").exists()
    capsys.readouterr()
    cb.on_multirun_end(OmegaConf.create({"report": True, "hydra": {"sweep": {"dir": str(sweep)}}}))
    assert (sweep / "report" / "report.md").is_file()
    # the HTML site beside it, its path printed
    assert (sweep / "report" / "index.html").is_file()
    assert f"html: {sweep / 'report' / 'index.html'}" in capsys.readouterr().out
    assert _status(sweep) == {"status": "ok", "problems": [], "invocation": "inv-1"}
    # No record at all (every job failed, each said why): one quiet line, no failure.
    capsys.readouterr()
    cb.on_multirun_end(OmegaConf.create({"hydra": {"sweep": {"dir": str(tmp_path / "none")}}}))
    assert "no run was recorded" in capsys.readouterr().err
    assert _status(tmp_path / "none")["status"] == "no_records"
    # A report that cannot be built prints one line and says so on disk; it never raises.
    import vpid_bench.report.build as build

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(build, "build_report", broken)
    cb.on_multirun_end(OmegaConf.create({"hydra": {"sweep": {"dir": str(sweep)}}}))
    assert capsys.readouterr().err.count("\n") == 1
    status = _status(sweep)
    assert status["status"] == "failed" and "disk full" in status["problems"][0]


def test_importing_the_callbacks_is_cheap():
    code = ("import sys, vpid_bench.shell.callbacks; "
            "print(sorted(m for m in ('pandas', 'seaborn', 'matplotlib', 'scikit_posthocs') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_job_folder_names_stay_one_safe_component():
    assert job_dir_name("optimizer=de1,problem.ps=20") == "optimizer=de1,problem.ps=20"
    escaped = job_dir_name("problem.reference.file=../../../x/ref.csv")
    assert "/" not in escaped and escaped.startswith("problem.reference.file=..%2F")
    assert job_dir_name("..") not in (".", "..") and job_dir_name("") == "job"
    long = job_dir_name(",".join(f"problem.k{i}=" + "v" * 20 for i in range(14)))
    assert len(long) <= callbacks.MAX_JOB_DIR and "/" not in long
    other = job_dir_name(",".join(f"problem.k{i}=" + "w" * 20 for i in range(14)))
    assert long != other  # the hash keeps long names apart


def test_an_unpickled_callback_registers_the_resolver(monkeypatch):
    """Launchers ship callbacks to their workers by pickling: the folder-name resolver must
    exist there before the worker resolves its job folder."""
    cb = ReportCallback()
    blob = pickle.dumps(cb)
    OmegaConf.clear_resolver(callbacks.JOB_DIR_RESOLVER)
    assert not OmegaConf.has_resolver(callbacks.JOB_DIR_RESOLVER)
    pickle.loads(blob)
    assert OmegaConf.has_resolver(callbacks.JOB_DIR_RESOLVER)
