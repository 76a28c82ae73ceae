"""``glob()`` sweeps over optimizer names: the pre-flight plans exactly the job folders Hydra
then makes (it once crashed with a traceback, "ConfigLoader is not set", on the README's own
``optimizer=glob(de*)``), with each of glob's forms."""

from __future__ import annotations

import pytest
from sweep_helpers import planned_job_dirs, run_cli

from vpid_bench.plugins import Registry

# the cheap problem: what is tested is the optimizers' folders, the same on any problem
TINY = ["problem=functions", "problem.iterations=1", "runs=1", "progress=false", "report=false"]


@pytest.mark.parametrize("pattern, expect", [
    ("glob(de*)", lambda names: [n for n in names if n.startswith("de")]),
    ("glob([de1,de4])", lambda names: ["de1", "de4"]),
    ("glob(*,exclude=[lsq,de_lsq,nevergrad,cmaes])",
     lambda names: [n for n in names if n not in ("lsq", "de_lsq", "nevergrad", "cmaes")]),
])
def test_the_plan_names_one_folder_per_matching_optimizer(tmp_path, pattern, expect):
    names = sorted(Registry().optimizers)
    dirs = planned_job_dirs(["-m", f"optimizer={pattern}", *TINY,
                             f"hydra.sweep.dir={tmp_path}"])
    planned = sorted(d.name.split(",")[0].removeprefix("optimizer=") for d in dirs)
    assert planned == sorted(expect(names)) and planned
    assert all(d.parent == tmp_path for d in dirs)


def test_a_glob_sweep_runs_and_makes_the_planned_folders(tmp_path):
    args = ["-m", "optimizer=glob([de1,random])", *TINY, "hydra.sweep.dir=sweep"]
    planned = planned_job_dirs([*args[:-1], f"hydra.sweep.dir={tmp_path / 'sweep'}"])
    out = run_cli(args, tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "Traceback" not in out.stderr
    made = sorted(p for p in (tmp_path / "sweep").iterdir() if (p / "job.json").is_file())
    assert made == sorted(planned) and len(made) == 2


def test_a_glob_matching_nothing_is_refused_in_one_line(tmp_path):
    out = run_cli(["-m", "optimizer=glob(zz*)", *TINY, "hydra.sweep.dir=sweep"], tmp_path)
    assert out.returncode != 0 and "Traceback" not in out.stderr
    assert "optimizer" in out.stderr and "a pattern matching one of" in out.stderr


def test_the_plan_renders_values_as_hydra_does(tmp_path):
    """A float Hydra renders otherwise (0.000001 -> 1e-06) and a key given twice (the last
    wins, in the first's place): the planned folders are the ones the jobs write, so no empty
    folder is left and reported as a failed job."""
    args = ["-m", "problem=functions", "optimizer=random,de1", "runs=2", "runs=1",
            "run_timeout_s=0.000001", "problem.iterations=1", "progress=false", "report=false",
            "hydra.sweep.dir=sweep"]
    planned = planned_job_dirs([*args[:-1], f"hydra.sweep.dir={tmp_path / 'sweep'}"])
    out = run_cli(args, tmp_path)
    assert "Traceback" not in out.stderr and "job.json not written" not in out.stderr
    made = sorted(p for p in (tmp_path / "sweep").iterdir() if p.name.startswith("optimizer="))
    assert made == sorted(planned) and len(made) == 2
    assert all("run_timeout_s=1e-06" in p.name and "runs=1" in p.name for p in made)
