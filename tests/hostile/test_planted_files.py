"""Files planted where results are read back: a FIFO, a folder or a huge file under a record's
name is refused at once (the report once hung forever on a FIFO named like a record)."""

from __future__ import annotations

import os

import pytest
from extras import limit

from vpid_bench.experiment import run_from_config
from vpid_bench.fileio import read_text_limited
from vpid_bench.params import hydra_node


def test_read_text_limited_refuses_what_is_not_a_small_regular_file(tmp_path):
    good = tmp_path / "a.json"
    good.write_text("{}")
    assert read_text_limited(good) == "{}"
    (tmp_path / "dir.json").mkdir()
    os.mkfifo(tmp_path / "fifo.json")
    big = tmp_path / "big.json"
    big.write_bytes(b" " * 2048)
    for path, words in ((tmp_path / "dir.json", "not a regular file"),
                        (tmp_path / "fifo.json", "not a regular file"),
                        (big, "more than 1024")):
        with pytest.raises(OSError, match=words):
            read_text_limited(path, max_bytes=1024)


def test_a_fifo_among_the_records_is_skipped_not_waited_for(tmp_path, registry):
    """vpid-bench-report in a subprocess with a time limit (a hang fails, not blocks)."""
    import subprocess
    import sys

    from vpid_vehicle.config import VehicleConfig

    problem = hydra_node(VehicleConfig, "vehicle") | {"iterations": 1}
    cfg = {"problem": problem, "optimizer": {"name": "random"}, "seed": 0, "runs": 2,
           "progress": False, "report": False}
    run_from_config(cfg, tmp_path / "job", registry)
    os.mkfifo(tmp_path / "job" / "records" / "run-999-planted.json")
    (tmp_path / "job" / "records" / "run-998-folder.json").mkdir()
    out = subprocess.run(
        [sys.executable, "-c", "from vpid_bench.report.cli import main; main()",
         str(tmp_path / "job"), "-o", str(tmp_path / "report")],
        capture_output=True, text=True, timeout=limit(120), check=False,
        env={**os.environ, "MPLBACKEND": "Agg"})
    assert out.returncode in (0, 1), out.stderr[-2000:]  # 1: it names what it skipped
    assert (tmp_path / "report" / "report.md").is_file()
    assert "run-999-planted.json" in out.stderr and "not a regular file" in out.stderr


def test_an_artifact_written_outside_the_job_folder_fails_the_job(tmp_path, registry_of):
    """A problem whose write_artifacts says it wrote ``../escaped.txt`` is refused before any
    run, naming the path; artifacts inside the folder are fine."""
    import numpy as np

    from vpid_bench import Bounds, PluginError, Problem, ProblemConfig, hookimpl

    class Leaky(Problem):
        Config = ProblemConfig
        target = "../escaped.txt"

        @property
        def bounds(self):
            return Bounds(np.zeros(2), np.ones(2), ("a", "b"))

        def evaluate(self, X):
            return np.sum(np.atleast_2d(X) ** 2, axis=1)

        def write_artifacts(self, directory):
            path = directory / self.target
            path.write_text("x")
            return [path]

    class Tidy(Leaky):
        target = "inside.txt"

    class Plugin:
        @hookimpl
        def vpid_bench_register_problems(self, register):
            register("leaky", Leaky)
            register("tidy", Tidy)

    import vpid_baselines.plugin

    registry = registry_of(("leaky", Plugin()), ("baselines", vpid_baselines.plugin))
    cfg = {"problem": {"name": "tidy"}, "optimizer": {"name": "random"}, "seed": 0, "runs": 1,
           "progress": False, "report": False}
    run_from_config(cfg, tmp_path / "tidy", registry)
    assert (tmp_path / "tidy" / "inside.txt").is_file()
    with pytest.raises(PluginError, match=r"write_artifacts wrote .*escaped.txt outside"):
        run_from_config({**cfg, "problem": {"name": "leaky"}}, tmp_path / "job", registry)
    assert not list((tmp_path / "job").glob("records/run-*.json"))
