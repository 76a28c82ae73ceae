"""A third party's problem that implements half of a capability (instance(i) without
instance_id(), as a plugin written from an older README did) is refused by the command before
any job: one ``error:`` line, exit 2, no sweep folder. It used to run, and judge every run
against instance 0's optimum without a word."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from extras import limit

BIN = Path(sys.executable).parent

PYPROJECT = """\
[build-system]
requires = ["setuptools>=68"]
build-backend = "setuptools.build_meta"

[project]
name = "half-instances"
version = "0.1"

[project.entry-points.vpid_bench]
half = "half_instances"
"""

MODULE = '''\
import numpy as np

from vpid_bench import Bounds, Problem, ProblemConfig, hookimpl


class Half(Problem):
    Config = ProblemConfig

    @property
    def bounds(self):
        return Bounds(np.zeros(2), np.ones(2), ("a", "b"))

    @property
    def x_true(self):
        return np.full(2, 0.3)

    def evaluate(self, X):
        return np.sum((np.atleast_2d(X) - self.shift) ** 2, axis=1)

    shift = 0.3

    def instance(self, index):
        other = Half(self.config)
        other.shift = 0.3 + 0.01 * index
        return other


@hookimpl
def vpid_bench_register_problems(register):
    register("half_instances", Half)
'''


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    src = tmp_path_factory.mktemp("src")
    (src / "pyproject.toml").write_text(PYPROJECT)
    (src / "half_instances.py").write_text(textwrap.dedent(MODULE))
    target = tmp_path_factory.mktemp("site")
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--target", str(target), str(src)],
                   check=True, capture_output=True, text=True)
    return target


def test_half_a_capability_is_one_error_line_before_any_job(site, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(site)}
    env.pop("VPID_BENCH_DEBUG", None)
    out = subprocess.run([str(BIN / "vpid-bench"), "-m", "problem=half_instances",
                          "optimizer=random,de1", "runs=2", "progress=false",
                          "hydra.sweep.dir=sweep"], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=limit(120))
    assert out.returncode == 2, out.stderr
    lines = [line for line in out.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: problem='half_instances'"), lines
    assert "but not instance_id()" in lines[0]
    assert not (tmp_path / "sweep").exists()
