"""A third-party plugin round trip: the README's example plugin, pip-installed into a folder
on PYTHONPATH, becomes `optimizer=local_search` on the command line with no change here."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent


def readme_example_files() -> dict[str, str]:
    """The files of the README's "Write an optimizer plugin" example, by file name."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    pattern = re.compile(r"<!-- example-plugin: (\S+) -->\s*```\w*\n(.*?)```", re.S)
    return {name: body for name, body in pattern.findall(text)}


@pytest.fixture(scope="module")
def installed_plugin(tmp_path_factory) -> Path:
    files = readme_example_files()
    assert set(files) == {"pyproject.toml", "my_local_search.py"}
    src = tmp_path_factory.mktemp("src")
    for name, body in files.items():
        (src / name).write_text(body, encoding="utf-8")
    (src / "pyproject.toml").write_text(
        files["pyproject.toml"]
        + '\n[build-system]\nrequires = ["setuptools"]\nbuild-backend = "setuptools.build_meta"\n'
        + '\n[tool.setuptools]\npy-modules = ["my_local_search"]\n'
    )
    site = tmp_path_factory.mktemp("site")
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
         "--target", str(site), str(src)],
        check=True, capture_output=True, text=True,
    )
    assert list(site.glob("my_local_search-*.dist-info/entry_points.txt"))
    return site


def _run(site: Path, args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(site), "MPLBACKEND": "Agg"}
    return subprocess.run([str(BIN / "vpid-bench"), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_installed_plugin_runs_from_the_command_line(installed_plugin, tmp_path):
    proc = _run(installed_plugin, ["problem=functions", "optimizer=local_search",
                                   "optimizer.sigma=0.05", "runs=2", "problem.iterations=3",
                                   "report=false", f"hydra.run.dir={tmp_path}/job"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    records = sorted((tmp_path / "job" / "records").glob("run-*.json"))
    assert len(records) == 2
    rec = json.loads(records[0].read_text())
    assert rec["optimizer"]["name"] == "local_search"
    assert rec["optimizer"]["params"]["sigma"] == 0.05
    assert rec["optimizer"]["plugin"]["distribution"] == "my-local-search"
    assert rec["optimizer"]["plugin"]["version"] == "0.1.0"
    assert rec["result"]["evaluations"] == 20 * 4


def test_installed_plugin_rejects_an_unknown_parameter(installed_plugin, tmp_path):
    proc = _run(installed_plugin, ["problem=functions", "optimizer=local_search",
                                   "+optimizer.sigmaa=1", "runs=1", "report=false",
                                   f"hydra.run.dir={tmp_path}/job"], tmp_path)
    assert proc.returncode != 0
    assert "optimizer.sigmaa" in proc.stderr and "sigma" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_help_lists_the_third_party_optimizer(installed_plugin, tmp_path):
    proc = _run(installed_plugin, ["--help", "problem=functions", "optimizer=random"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    choices = proc.stdout.split("== Choices (group=option) ==")[1].split("== Config")[0]
    assert "local_search" in choices and "random" in choices
