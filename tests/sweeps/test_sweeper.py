"""vpid-bench's default sweeper: each point of a sweep is composed once at launch, not a
second time to validate the batch (the pre-flight has checked every point), with the job
folders and records of Hydra's basic sweeper."""

from __future__ import annotations

import subprocess
import sys

import pytest
from sweep_helpers import cli_env, fingerprints

#: Runs ``vpid-bench`` in a subprocess and prints how often Hydra composed a job's config.
COUNTING = """
import atexit, sys
from hydra._internal.config_loader_impl import ConfigLoaderImpl
calls = []
original = ConfigLoaderImpl.load_sweep_config
def counted(self, *args, **kwargs):
    calls.append(1)
    return original(self, *args, **kwargs)
ConfigLoaderImpl.load_sweep_config = counted
atexit.register(lambda: print("COMPOSED", len(calls)))
from vpid_bench.shell.main import main
main(sys.argv[1:])
"""

SWEEP = ["-m", "problem=functions", "optimizer=random,de1", "problem.ps=10,12", "runs=2",
         "problem.iterations=3", "progress=false", "report=false"]


def _sweep(tmp_path, name: str, *extra: str) -> tuple[int, str]:
    done = subprocess.run([sys.executable, "-c", COUNTING, *SWEEP, *extra,
                           f"hydra.sweep.dir={tmp_path / name}"], cwd=tmp_path,
                          env=cli_env(), capture_output=True, text=True, timeout=180,
                          check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    count = [line for line in done.stdout.splitlines() if line.startswith("COMPOSED")]
    return int(count[-1].split()[1]), done.stdout


def test_each_point_is_composed_once_with_the_same_records_as_the_basic_sweeper(tmp_path):
    ours, _ = _sweep(tmp_path, "ours")
    basic, _ = _sweep(tmp_path, "basic", "hydra/sweeper=basic")
    assert ours == 4  # the launch of each of the 4 jobs, no validation pass
    assert basic == 8  # Hydra's basic sweeper: validation and launch
    assert "PreflightSweeper" in (tmp_path / "ours" / "multirun.yaml").read_text()
    ours_records, basic_records = fingerprints(tmp_path / "ours"), fingerprints(tmp_path / "basic")
    assert len(ours_records) == 8 and ours_records == basic_records


def test_the_sweeper_is_known_to_hydra_even_when_its_scan_misses_it():
    from hydra._internal.core_plugins import basic_sweeper
    from hydra.core.plugins import Plugins
    from hydra_plugins.vpid_bench_sweeper import PreflightSweeper

    from vpid_bench.shell.config_store import SWEEPER, ensure_sweeper_known

    plugins = Plugins.instance()
    plugins.class_name_to_class.pop(SWEEPER["_target_"], None)  # as an editable install hides it
    ensure_sweeper_known()
    registered = plugins.class_name_to_class[SWEEPER["_target_"]]
    assert registered.__name__ == PreflightSweeper.__name__
    # it wraps the BasicSweeper of the module as it is now (Hydra's scan re-executes that
    # module, so a class bound before the scan would be stale)
    sweeper = registered(max_batch_size=None, params=None)
    assert type(sweeper.basic) is basic_sweeper.BasicSweeper
    assert sweeper.basic.validate_batch_is_legal([["optimizer=nosuch"]]) is None


@pytest.mark.parametrize("bad", ["optimizer=random,nosuch", "problem.ps=10,-3"])
def test_a_bad_point_still_stops_the_sweep_before_any_job(tmp_path, bad):
    """Without the sweeper's validation the pre-flight is what refuses a bad point."""
    args = [a for a in SWEEP if not a.startswith(bad.split("=")[0] + "=")]
    done = subprocess.run([sys.executable, "-c", COUNTING, *args, bad,
                           f"hydra.sweep.dir={tmp_path / 'bad'}"], cwd=tmp_path, env=cli_env(),
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 2 and done.stderr.startswith("error: ")
    assert "COMPOSED 0" in done.stdout and not (tmp_path / "bad").exists()
