"""What a new user meets in the first hour (issue 12): Hydra's own flags work, the version
names every plugin, BLAS threads are pinned in a job, compilation is not timed."""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from extras import limit

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402

from vpid_bench import Optimizer, OptimizerParams, Problem, ProblemConfig, hookimpl  # noqa: E402
from vpid_bench.api import Bounds  # noqa: E402
from vpid_bench.experiment import run_from_config  # noqa: E402
from vpid_bench.plugins import Registry, get_plugin_manager  # noqa: E402


def _console(args: list[str], cwd: Path, env: dict | None = None):
    import os
    import subprocess

    exe = Path(sys.executable).with_name("vpid-bench")
    return subprocess.run([str(exe), *args], cwd=cwd, capture_output=True, text=True,
                          timeout=limit(120), env={**os.environ, **(env or {})})


def test_shell_completion_can_be_installed_and_queried(tmp_path):
    done = _console(["-sc", "install=bash"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert "complete -o nospace -o default -F hydra_bash_completion vpid-bench" in done.stdout
    query = _console(["-sc", "query=bash"], tmp_path, {"COMP_LINE": "vpid-bench optimizer=de"})
    assert query.returncode == 0, query.stderr
    assert "optimizer=de1" in query.stdout.split()
    alone = _console(["-sc", "query=bash"], tmp_path)  # not from a shell: one line, exit 2
    assert alone.returncode == 2 and alone.stderr.count("\n") == 1
    assert alone.stderr.startswith("error: -sc='query=bash' is not allowed: install=bash")


def test_cfg_shows_the_composed_config_of_a_single_run(tmp_path):
    done = run_cli(["--cfg", "job", "optimizer=de1"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert "runs: 30" in done.stdout and "name: de1" in done.stdout
    assert not (tmp_path / "outputs").exists()  # showing a config runs nothing


def test_version_names_vpid_bench_and_every_plugin(tmp_path):
    done = run_cli(["--version"], tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("vpid-bench ")
    for plugin in ("vehicle", "de", "ga", "baselines", "peers"):
        assert any(line.startswith(f"  plugin {plugin}: vpid-bench ") for line in lines), lines


@dataclasses.dataclass(frozen=True)
class _Cfg(ProblemConfig):
    dim: int = 3


class _BlasProbe(Problem):
    """Records how many threads numpy's BLAS may use while the job evaluates."""

    Config = _Cfg
    seen: list[int] = []  # noqa: RUF012 - a test probe

    @property
    def bounds(self) -> Bounds:
        return Bounds(np.zeros(3), np.ones(3), ("a", "b", "c"))

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        from threadpoolctl import threadpool_info

        blas = [p["num_threads"] for p in threadpool_info() if p.get("user_api") == "blas"]
        _BlasProbe.seen.extend(blas)
        return np.sum(X * X, axis=1)


class _SlowFirstCall(Optimizer):
    """Stands for an optimizer whose first use in a process compiles something (0.3 s)."""

    Params = OptimizerParams
    compiled = False

    def ask(self) -> np.ndarray:
        if not _SlowFirstCall.compiled:
            time.sleep(0.3)
            _SlowFirstCall.compiled = True
        return self.bounds.sample(self.rng, self.params.ps)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        pass


class _Plugin:
    @hookimpl
    def vpid_bench_register_problems(self, register):
        register("blas_probe", _BlasProbe)

    @hookimpl
    def vpid_bench_register_optimizers(self, register):
        register("slow_first", _SlowFirstCall)


@pytest.fixture
def registry_with_probes():
    return Registry(get_plugin_manager(extra_plugins=[("probes", _Plugin())]))


def test_a_job_pins_blas_to_one_thread_unless_the_user_set_it(registry_with_probes, tmp_path,
                                                              monkeypatch):
    pytest.importorskip("threadpoolctl")
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                "VPID_BENCH_BLAS_THREADS"):
        monkeypatch.delenv(var, raising=False)
    _BlasProbe.seen.clear()
    cfg = {"problem": {"name": "blas_probe", "ps": 4, "iterations": 2},
           "optimizer": {"name": "random"}, "runs": 1, "progress": False}
    run_from_config(cfg, tmp_path / "job", registry_with_probes)
    if not _BlasProbe.seen:
        pytest.skip("numpy reports no BLAS thread pool here")
    assert set(_BlasProbe.seen) == {1}


def test_compilation_is_not_timed_as_part_of_the_first_run(registry_with_probes, tmp_path):
    _SlowFirstCall.compiled = False
    cfg = {"problem": {"name": "blas_probe", "ps": 4, "iterations": 2},
           "optimizer": {"name": "slow_first"}, "runs": 3, "progress": False}
    summary = run_from_config(cfg, tmp_path / "job", registry_with_probes)
    import json

    times = [json.loads(p.read_text())["timing"]["run_time_s"] for p in summary.record_paths]
    assert summary.warmup_s >= 0.3  # the one-off cost went to the untimed warm-up
    assert max(times) < 0.2, times  # no run carries it
