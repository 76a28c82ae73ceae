"""Launchers: the joblib launcher (2 worker processes) writes records bit-identical to the
basic launcher's (apart from timing), and a job that fails in a worker process still makes
the command exit non-zero and is named in the sweep summary.

Beyond one process (marker ``scaleout``, excluded by default; ``make test-scaleout`` runs them
in their own environment with the ``ray`` extra): Hydra's Ray launcher on a local Ray instance
and submitit's launcher on its local executor write the same records as the basic launcher,
and so does the archive build (``tools/build_archive.py``, a slice) run unchanged through
them."""

from __future__ import annotations

import pytest
from extras import installed, needs
from sweep_helpers import fingerprints, planned_job_dirs, run_cli
from test_build_archive import build

# Three jobs fail in every launcher: a folder planted where they write reference.csv (a fault
# of the job folder, which no pre-flight can see), so the job fails after it started.
SWEEP = ["-m", "optimizer=random,de1,ga", "problem.noise.seed=0,1", "runs=3",
         "problem.iterations=2", "progress=false", "report=false"]
OK_JOBS = 3


#: The joblib launcher comes with an extra (installed by ``make install``); without it the
#: cases that name it are skipped, not failed.
NEEDS_JOBLIB = needs("hydra_plugins.hydra_joblib_launcher", "joblib")


def _run(cwd, *extra, **kwargs):
    args = [*SWEEP, *extra, "hydra.sweep.dir=sweep"]
    for job_dir in planned_job_dirs([*args[:-1], f"hydra.sweep.dir={cwd / 'sweep'}"]):
        if "problem.noise.seed=1" in job_dir.name:
            (job_dir / "reference.csv").mkdir(parents=True)
    return run_cli(args, cwd, **kwargs)


@pytest.fixture(scope="module")
def basic(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("basic")
    return cwd, _run(cwd)


def _check_failed_job_reported(done) -> None:
    assert done.returncode == 1, done.stderr
    assert "sweep: 6 job(s), 3 ok, 3 not ok" in done.stderr
    summary = [line for line in done.stderr.splitlines() if line.startswith("  error: ")]
    assert len(summary) == 3  # one line per failed job, whichever process ran it
    assert all("problem.noise.seed=1" in line and "IsADirectoryError" in line
               for line in summary)
    assert "Traceback" not in done.stderr


def test_basic_launcher_reports_the_failed_jobs(basic):
    cwd, done = basic
    _check_failed_job_reported(done)
    assert len(fingerprints(cwd / "sweep")) == OK_JOBS * 3


@NEEDS_JOBLIB
def test_joblib_records_are_bit_identical_to_basic(basic, tmp_path):
    cwd, _ = basic
    done = _run(tmp_path, "hydra/launcher=joblib", "hydra.launcher.n_jobs=2")
    _check_failed_job_reported(done)
    assert "Joblib.Parallel" in done.stdout + done.stderr  # it ran in the joblib launcher
    assert fingerprints(tmp_path / "sweep") == fingerprints(cwd / "sweep")


@pytest.mark.scaleout
@needs("hydra_plugins.hydra_submitit_launcher", "submitit")
def test_submitit_local_records_match_basic(basic, tmp_path):
    cwd, _ = basic
    done = _run(tmp_path, "hydra/launcher=submitit_local", timeout=300)
    _check_failed_job_reported(done)
    assert fingerprints(tmp_path / "sweep") == fingerprints(cwd / "sweep")


@pytest.mark.scaleout
def test_ray_local_records_match_basic(basic, tmp_path):
    pytest.importorskip("ray", reason="Ray not installed (extra 'ray': make test-scaleout)")
    if not installed("hydra_plugins.hydra_ray_launcher"):
        pytest.skip("hydra-ray-launcher not installed (extra 'ray': make test-scaleout)")
    cwd, _ = basic
    done = _run(tmp_path, "hydra/launcher=ray", "+hydra.launcher.ray.init.num_cpus=2",
                "+hydra.launcher.ray.init.include_dashboard=false", timeout=600)
    _check_failed_job_reported(done)
    assert "Ray" in done.stdout + done.stderr  # it ran in the Ray launcher
    assert fingerprints(tmp_path / "sweep") == fingerprints(cwd / "sweep")


@pytest.fixture(scope="module")
def basic_build(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("basic_build")
    done = build(tmp)
    assert done.returncode == 0, done.stderr[-3000:]
    return tmp


RAY = ["hydra/launcher=ray", "+hydra.launcher.ray.init.num_cpus=2",
       "+hydra.launcher.ray.init.include_dashboard=false"]


@pytest.mark.scaleout
@pytest.mark.parametrize("launcher", [["hydra/launcher=submitit_local"], RAY],
                         ids=["submitit_local", "ray"])
def test_the_archive_build_runs_unchanged_through_a_launcher(basic_build, tmp_path, launcher):
    """The build's two sweeps (certify, then the runs with stop at the target, which find the
    certified optima through the environment) in the launcher's processes: the records are
    the basic launcher's, bit for bit apart from timing, and the archive packs the same
    runs."""
    if launcher == RAY:
        pytest.importorskip("ray", reason="Ray not installed (make test-scaleout)")
    name = "hydra_submitit_launcher" if launcher != RAY else "hydra_ray_launcher"
    if not installed(f"hydra_plugins.{name}"):
        pytest.skip(f"{name} not installed (make test-scaleout)")
    done = build(tmp_path, *launcher, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    assert ("Ray" if launcher == RAY else "Submitit") in done.stdout + done.stderr
    assert fingerprints(tmp_path / "b") == fingerprints(basic_build / "b")
    assert len(fingerprints(tmp_path / "b")) == 2 + 4  # certify: 2 runs; runs: 2 x 2
