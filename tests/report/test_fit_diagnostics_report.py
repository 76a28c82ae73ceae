"""The fit diagnostics in a report (vpid_bench/report/diagnostics.py): a record made by a
richer model than the fitted one (a decay with an oscillation the model lacks) gets ONE plain
line saying the residuals are correlated, on the first screen (terminal), in report.md and
in the HTML, with the residual figure and the robust interval trusted; a record the model
explains says so."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from vpid_bench.api import Bounds, Problem, ProblemConfig
from vpid_bench.experiment import run_job
from vpid_bench.plugins import Registry
from vpid_bench.report.build import build_report
from vpid_bench.report.diagnostics import plain_line
from vpid_bench.spec import Job, JobSpec
from vpid_bench.store.job_checks import read_diagnostics

T = np.linspace(0.0, 3.0, 600)
HIDDEN = np.array([2.0, 1.5, 0.3])


def _decay(X, t):
    a, b, c = np.atleast_2d(X).T
    return a[:, None] * np.exp(-b[:, None] * t[None]) + c[:, None]


@dataclasses.dataclass(frozen=True)
class RichConfig(ProblemConfig):
    """``wobble``: amplitude of the oscillation the fitted model lacks (0: none)."""

    wobble: float = 0.2


class Rich(Problem):
    """``y = a exp(-b t) + c`` fitted to a record that also holds ``wobble sin(4 t)``, and
    exposes the input ``t`` (a ramp) for the cross-correlation."""

    Config = RichConfig
    name = "rich"
    rows_independent = True

    def __init__(self, config: RichConfig) -> None:
        super().__init__(config)
        rng = np.random.default_rng(3)
        self.y = (_decay(HIDDEN, T)[0] + config.wobble * np.sin(4 * T)
                  + 0.02 * rng.standard_normal(T.size))

    @property
    def bounds(self) -> Bounds:
        return Bounds(np.array([0.5, 0.5, -1.0]), np.array([4.0, 3.0, 1.0]), ("a", "b", "c"),
                      ("m", "1/s", "m"))

    def residuals(self, X):
        return self.y[None] - _decay(X, T)

    def evaluate(self, X):
        return np.sum(self.residuals(X) ** 2, axis=1)

    def diagnostic_signals(self, x):
        return {"measured": self.y, "names": ["y"], "inputs": {"ramp": T}}


def _sweep(root: Path, wobble: float) -> Path:
    reg = Registry()
    for name in ("lsq", "random"):
        cls = reg.optimizers[name]
        job = Job(JobSpec(runs=2, progress=False, report=False, isolation="none"), "rich",
                  Rich, RichConfig(ps=10, iterations=5, wobble=wobble), name, cls,
                  cls.Params(ps=10, iterations=5, budget=60), 60)
        run_job(job, root / f"optimizer={name}", optima_dir=root / "optima")
    return root


@pytest.fixture(scope="module")
def rich(tmp_path_factory):
    root = _sweep(tmp_path_factory.mktemp("rich"), 0.2)
    return root, build_report([root], root / "report")


def test_the_job_writes_its_diagnostics_and_both_intervals(rich):
    root, _ = rich
    data = json.loads((root / "optimizer=lsq" / "diagnostics.json").read_text())
    assert data["status"] == "ok" and data["explained"] is False
    g = data["groups"][0]
    assert g["name"] == "y" and g["correlated"] and g["lag1"] > 0.9
    assert g["rms_over_signal"] < 0.2 and g["sigma_source"] == "estimated"
    assert set(g["cross"]) == {"ramp"}
    iv = data["intervals"]
    ratio = np.array(iv["robust"]["se"]) / np.array(iv["se"])
    assert iv["assumes"] == "white residuals" and np.all(ratio > 3), (ratio, g["lag1"])


def test_one_plain_line_on_every_screen_and_the_robust_interval_trusted(rich):
    root, report = rich
    md = (root / "report" / "report.md").read_text()
    results = md[md.index("## Results"):md.index("\n## ", md.index("## Results"))]
    line = plain_line(read_diagnostics(root / "optimizer=lsq" / "diagnostics.json"))
    assert line.startswith("The residuals are correlated (lag-1 0.9")
    assert "the model misses dynamics the record holds" in line
    flat = " ".join(results.split())
    assert line in flat and "robust (HAC" in flat and "not the system that made it" in flat
    assert " ".join(report.headline.split()).count("The residuals are correlated") == 1
    html = (root / "report" / "index.html").read_text()
    assert "The residuals are correlated" in " ".join(html.split())
    # the residual figure, in Markdown and on the problem's page
    assert "residuals_rich" in md
    page = (root / "report" / "problem-rich.html").read_text()
    assert "residuals_rich" in page
    assert list((root / "report").rglob("residuals_rich*.png"))


def test_a_record_the_model_explains_says_so(tmp_path):
    root = _sweep(tmp_path, 0.0)
    report = build_report([root], root / "report", short=True)
    flat = " ".join(report.headline.split())
    assert "The residuals look like noise" in flat and "correlated" not in flat
    assert "white-noise (Jacobian) interval is trusted" in flat
