"""Issue 35, failure 16: a plugin whose code changed, reinstalled under the same version (as one
does while developing it), was served its old records without a word, though the README
promises a changed plugin is never silently reused. Each run's id now holds a digest of the
plugin's installed source (:func:`vpid_bench.store.provenance.code_digest`): the old
records are set aside with one line saying the plugin's code changed, and the runs are run
again. The same code keeps its records."""

from __future__ import annotations

import json
from pathlib import Path

from hostile_helpers import run_cli

PLUGIN = '''
from dataclasses import dataclass

import numpy as np

from vpid_bench import Optimizer, OptimizerParams, hookimpl


@dataclass(frozen=True)
class StepParams(OptimizerParams):
    pass


class Step(Optimizer):
    """Uniform samples, shifted by STEP of the box (the line a developer edits)."""

    Params = StepParams
    STEP = {step}

    def ask(self):
        X = self.bounds.sample(self.rng, self.params.ps)
        return np.clip(X + self.STEP * self.bounds.width, self.bounds.lower, self.bounds.upper)

    def tell(self, X, f):
        pass


@hookimpl
def vpid_bench_register_optimizers(register):
    register("devstep", Step)
'''
JOB = ["problem=functions", "optimizer=devstep", "runs=2", "problem.iterations=2",
       "progress=false", "report=false", "hydra.run.dir=job"]


def _install(site: Path, step: float) -> None:
    """The plugin as an installed distribution ``vpid-devstep 0.1`` (always version 0.1)."""
    info = site / "vpid_devstep-0.1.dist-info"
    info.mkdir(parents=True, exist_ok=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: vpid-devstep\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[vpid_bench]\ndevstep = vpid_devstep\n")
    (site / "vpid_devstep.py").write_text(PLUGIN.format(step=step))


def _records(tmp_path: Path) -> dict[int, dict]:
    return {r["run_index"]: r for r in (json.loads(p.read_text())
                                        for p in (tmp_path / "job").glob("records/run-*.json"))}


def test_16_a_plugin_changed_under_the_same_version_is_run_again(tmp_path):
    site = tmp_path / "site"
    env = {"PYTHONPATH": str(site)}
    _install(site, 0.0)
    first = run_cli(JOB, tmp_path, env=env)
    assert first.returncode == 0, first.stderr
    before = _records(tmp_path)
    assert {r["optimizer"]["plugin"]["version"] for r in before.values()} == {"0.1"}
    same = run_cli(JOB, tmp_path, env=env)  # the control: the same code keeps its records
    assert "0 run(s) done, 2 already recorded" in same.stderr, same.stderr
    _install(site, 0.01)  # edited and reinstalled, still version 0.1
    again = run_cli(JOB, tmp_path, env=env)
    assert again.returncode == 0, again.stderr
    assert "2 run(s) done, 0 already recorded" in again.stderr, again.stderr
    (line,) = [w for w in again.stderr.splitlines() if "set aside" in w]
    assert line.startswith("warning: 2 record(s) in ")
    assert ("by other code of the optimizer plugin devstep (its installed source changed under "
            "the same version 0.1)") in line
    after = _records(tmp_path)
    assert len(after) == 2 and len(list((tmp_path / "job").glob("records/superseded/*"))) == 2
    for i in (0, 1):
        old, new = before[i]["optimizer"]["plugin"], after[i]["optimizer"]["plugin"]
        assert old["version"] == new["version"] == "0.1" and old["code"] != new["code"]
        assert before[i]["result"]["x_best"] != after[i]["result"]["x_best"]  # not reused
