"""A problem without a truth (``x_true`` None, a measured record): each run's 95 %
intervals in its record, the profile likelihood and the comparison rows in the job folder,
and a report that says so on its first screen and measures nothing against nominal values."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from vpid_bench.analysis.estimates import comparison_rows
from vpid_bench.api import Bounds, Problem, ProblemConfig
from vpid_bench.experiment import run_job
from vpid_bench.plugins import Registry
from vpid_bench.report.build import Report, build_report
from vpid_bench.spec import Job, JobSpec

T = np.linspace(0.0, 3.0, 300)
#: The parameters that made the records; the problem never tells them.
HIDDEN = np.array([2.0, 1.5, 0.3])


def _decay(X, t):
    a, b, c = np.atleast_2d(X).T
    return a[:, None] * np.exp(-b[:, None] * t[None]) + c[:, None]


@dataclasses.dataclass(frozen=True)
class DecayConfig(ProblemConfig):
    """Noise of the two records (estimation, validation)."""

    sigma: float = 0.05


class Decay(Problem):
    """``y = a exp(-b t) + c`` fitted on one record, judged on a held-out one."""

    Config = DecayConfig
    name = "decay"
    rows_independent = True

    def __init__(self, config: DecayConfig) -> None:
        super().__init__(config)
        rng = np.random.default_rng(7)
        self.y = _decay(HIDDEN, T)[0] + config.sigma * rng.standard_normal(T.size)
        self.y_val = _decay(HIDDEN, T)[0] + config.sigma * rng.standard_normal(T.size)

    @property
    def bounds(self) -> Bounds:
        return Bounds(np.array([0.5, 0.5, 0.0]), np.array([4.0, 3.0, 1.0]), ("a", "b", "c"),
                      ("m", "1/s", "m"))

    def residuals(self, X):
        return self.y[None] - _decay(X, T)

    def evaluate(self, X):
        return np.sum(self.residuals(X) ** 2, axis=1)

    def metrics(self, x):
        return {"val_rms": float(np.sqrt(np.mean((self.y_val - _decay(x, T)[0]) ** 2)))}

    def comparisons(self):
        return {"published estimate": {"x": [2.1, 1.4, 0.31], "note": "from a paper"},
                "naive predictor": {"metrics": {"val_rms": 0.9}, "note": "the mean held"}}

    def describe(self):
        """A stated quantity (the report's Assumed block; docs/architecture.md)."""
        return {"known": [{"name": "t_end", "value": 3.0, "unit": "s",
                           "source": "the record's length", "what": "record length"}]}


def _job(optimizer: str, runs: int = 3) -> Job:
    reg = Registry()
    cls = reg.optimizers[optimizer]
    config = DecayConfig(ps=10, iterations=5)
    params = cls.Params(ps=10, iterations=5, budget=60)
    return Job(JobSpec(runs=runs, progress=False, report=False, isolation="none"), "decay",
               Decay, config, optimizer, cls, params, 60)


def no_truth_sweep(root: Path) -> Report:
    """lsq and random search on the decay record (3 runs each) and the sweep's report in
    ``root/report`` (the browser tests open its overview too)."""
    for name in ("lsq", "random"):
        run_job(_job(name), root / f"optimizer={name}", optima_dir=root / "optima")
    return build_report([root], root / "report")


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Report:
    return no_truth_sweep(tmp_path_factory.mktemp("no_truth"))


@pytest.fixture(scope="module")
def sweep(report) -> Path:
    return report.out_dir.parent


def _records(folder: Path) -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted((folder / "records").glob("run-*.json"))]


def test_records_hold_intervals_and_no_error_against_anything(sweep):
    for rec in _records(sweep / "optimizer=lsq"):
        assert rec["parameters"]["true"] is None
        res = rec["result"]
        assert res["rel_error_percent"] is None and set(res["metrics"]) == {"val_rms"}
        iv = res["intervals"]
        x = np.array(res["x_best"])
        assert np.all(np.array(iv["lower"]) < x) and np.all(x < np.array(iv["upper"]))
        # the least-squares fit finds the hidden parameters within its interval
        assert np.all(np.array(iv["lower"]) < HIDDEN) and np.all(HIDDEN < np.array(iv["upper"]))
        assert iv["sigma"][0] == pytest.approx(0.05, rel=0.15)


def test_the_job_writes_the_profile_and_the_comparison_rows(sweep):
    prof = json.loads((sweep / "optimizer=lsq" / "profile.json").read_text())
    assert prof["status"] == "ok" and prof["classification"] == ["identifiable"] * 3
    assert all(lo < h < hi for lo, h, hi in zip(prof["lower"], HIDDEN, prof["upper"]))
    rows = json.loads((sweep / "optimizer=lsq" / "comparisons.json").read_text())["rows"]
    pub, naive = rows
    assert pub["name"] == "published estimate" and pub["x"] == [2.1, 1.4, 0.31]
    p = Decay(DecayConfig())
    assert pub["f"] == pytest.approx(float(p.evaluate(np.array([[2.1, 1.4, 0.31]]))[0]))
    assert pub["metrics"]["val_rms"] == pytest.approx(p.metrics(np.array([2.1, 1.4, 0.31]))
                                                      ["val_rms"])
    assert naive["f"] is None and naive["metrics"] == {"val_rms": 0.9}


def test_the_first_screen_says_there_is_no_truth_and_shows_the_intervals(sweep):
    text = (sweep / "report" / "report.md").read_text()
    start = text.index("## Results")
    results = text[start:text.index("\n## ", start)]
    assert "No truth" in results and "held out" in results
    assert "95 % interval (Jacobian)" in results and "95 % interval (profile)" in results
    assert "published estimate" in results and "naive predictor" in results
    assert "NoRE" not in text and "from the truth" not in results


def test_the_answer_gives_the_identified_values_first_and_no_truth(report):
    """Issue 46: the answer at the top of report.md and of the terminal holds the identified
    values with their intervals and the stated quantity; nothing in it names a truth."""
    md = report.report_md.read_text(encoding="utf-8")
    answer = md[md.index("## The answer"):md.index("## Results")]
    assert md.splitlines().index("## The answer") < 8
    assert "Identified on decay ps=10: the best run (lsq, run" in answer
    assert "| a         | m    |" in answer and "95 % interval (Jacobian)" in answer
    assert "t_end = 3 s (record length)" in " ".join(answer.split())
    assert "truth" not in md[:md.index("## Results")].lower()
    first = report.headline.splitlines()[:15]
    assert first[0] == "The answer"
    assert any(line.startswith("Identified on decay ps=10") for line in first)
    assert any(line.startswith("a          m") for line in first), first


def test_the_html_page_shows_the_intervals_too(sweep):
    """The same blocks on the problem's HTML page (one model, every renderer)."""
    text = (sweep / "report" / "problem-decay.html").read_text()
    assert "No truth" in text and "95 % interval (Jacobian)" in text
    assert "95 % interval (profile)" in text and "published estimate" in text
    assert "NoRE" not in text


def test_runs_table_has_no_relative_errors(sweep):
    import pandas as pd

    runs = pd.read_csv(sweep / "report" / "runs.csv")
    assert runs["metric_name"].eq("val_rms").all()
    assert runs.filter(like="eps.").isna().all().all()


def test_a_comparison_of_the_wrong_length_is_named():
    class Bad(Decay):
        def comparisons(self):
            return {"short": {"x": [1.0]}}

    with pytest.raises(ValueError, match="comparison 'short' has 1 values"):
        comparison_rows(Bad(DecayConfig()))
