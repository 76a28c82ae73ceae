"""Stop at the final target (``target=``): a run ends once it is within the target of its
instance's optimum certified in advance by an archive; its trace is the prefix of the same
run without the stop, so the fixed-target results are unchanged; a run whose instance has no
certified optimum is refused in one line."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402

from vpid_bench.report.anytime import hit_times  # noqa: E402
from vpid_bench.report.pack import pack  # noqa: E402
from vpid_bench.runner import Lane, run_many  # noqa: E402
from vpid_bench.store import archive as arch  # noqa: E402
from vpid_bench.store.archive_records import read_archive  # noqa: E402
from vpid_bench.targets import stop_value  # noqa: E402

KEYS = ["report=false", "isolation=none", "progress=false", "problem=smoke_quarter",
        "optimizer=de4"]


@pytest.fixture(scope="module")
def archives(tmp_path_factory, compose_config, registry) -> Path:
    """An archive of de4 on smoke_quarter (3 runs, so 3 certified instance optima), the
    sweep run in this process (what the command's job runs; the runs with a target below go
    through the command line)."""
    from vpid_bench.experiment import run_from_config

    root = tmp_path_factory.mktemp("target")
    keys = [k for k in KEYS if not k.startswith(("isolation", "progress", "report"))]
    run_from_config(compose_config([*keys, "runs=3", "archive=false", "report=false",
                                    "progress=false"]),
                    root / "base" / "optimizer=de4", registry, optima_dir=root / "base" / "optima")
    pack(root / "base", "smoke", root / "archives" / "smoke", command="test",
              commit=None, made_at="2026-01-01T00:00:00+00:00")
    return root / "archives"


def _records(folder: Path) -> dict[int, dict]:
    out = {}
    for p in sorted(folder.glob("records/run-*.json")):
        r = json.loads(p.read_text())
        out[r["run_index"]] = r
    return out


def _job(tmp_path: Path, archives: Path, *keys: str) -> tuple[object, Path]:
    out = tmp_path / "job"
    done = run_cli([*KEYS, *keys, f"hydra.run.dir={out}"], cwd=tmp_path,
                   env={arch.ARCHIVE_DIR_ENV: str(archives)})
    return done, out


def test_runs_stop_at_the_target_and_their_traces_are_prefixes(archives, tmp_path):
    done, out = _job(tmp_path, archives, "runs=3", "target=0.5")
    assert done.returncode == 0, done.stderr[-2000:]
    full = _records(archives.parent / "base" / next(
        p.name for p in (archives.parent / "base").iterdir() if "de4" in p.name))
    optima = {o.instance: o.f_opt for o in read_archive(archives / "smoke").optima}
    stopped = _records(out)
    assert len(stopped) == 3
    for i, r in stopped.items():
        f_opt = optima[r["instance"]["id"]]
        res, whole = r["result"], full[i]["result"]
        assert r["target"] == {"gap": 0.5, "f_stop": pytest.approx(stop_value(f_opt, 0.5))}
        assert res["stopped_by"] == "target" and whole["stopped_by"] == "budget"
        assert res["evaluations"] < whole["evaluations"]
        assert res["f_best"] <= r["target"]["f_stop"]
        n = len(r["trace"]["best"])
        assert r["trace"]["best"] == full[i]["trace"]["best"][:n]  # the same run, cut short
        assert full[i]["trace"]["best"][n - 2] > r["target"]["f_stop"]  # not a batch later
        # the hit times of every target down to the final one are those of the whole run
        targets = (1.0, 0.5)
        cut, whole_trace = r["trace"], full[i]["trace"]
        assert hit_times(cut["evaluations"], _gaps(cut, f_opt), targets) == \
            hit_times(whole_trace["evaluations"], _gaps(whole_trace, f_opt), targets)


def _gaps(trace: dict, f_opt: float) -> np.ndarray:
    return (np.asarray(trace["best"]) - f_opt) / abs(f_opt)


def test_a_run_without_a_certified_optimum_is_refused_in_one_line(archives, tmp_path):
    done, out = _job(tmp_path, archives, "runs=4", "target=1e-8")
    assert done.returncode != 0
    assert "target=1e-08 is not allowed" in done.stderr
    assert "smoke_quarter run 3 (instance seed=0/3) has none in the archives" in done.stderr
    assert "Traceback" not in done.stderr
    assert not list(out.glob("records/run-*.json"))


def test_other_settings_have_no_certified_optimum(archives, tmp_path):
    done, out = _job(tmp_path, archives, "runs=2", "target=1e-8", "problem.noise_level=0.1")
    assert done.returncode != 0 and "run 0 (instance" in done.stderr


@pytest.mark.parametrize("value", ["-1", "2", "nan"])
def test_a_bad_target_is_refused_before_any_work(tmp_path, value):
    done = run_cli([*KEYS, f"target={value}", f"hydra.run.dir={tmp_path / 'job'}"],
                   cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: target={float(value)} is not allowed"), done.stderr
    assert not (tmp_path / "job").exists()


def test_the_ledger_stops_after_the_batch_that_reaches_the_value():
    from vpid_bench.api import Bounds, Optimizer, OptimizerParams, Problem, ProblemConfig

    class Line(Problem):
        name = "line"
        Config = ProblemConfig

        @property
        def bounds(self):
            return Bounds(np.array([0.0]), np.array([10.0]), ("x",), ("",))

        def evaluate(self, X):
            return X[:, 0].copy()

    class Down(Optimizer):
        name = "down"
        Params = OptimizerParams

        def __init__(self, params, bounds, rng):
            super().__init__(params, bounds, rng)
            self.x = 10.0

        def ask(self):
            self.x -= 1.0
            return np.array([[self.x], [self.x + 0.5]])

        def tell(self, X, f):
            pass

    problem = Line(ProblemConfig())
    (out,) = run_many(problem, [Lane(problem, Down(OptimizerParams(), problem.bounds,
                                                   np.random.default_rng(0)), 100,
                                     stop_at=6.0)])
    assert out.stopped_by == "target" and out.f_best == 6.0 and out.evaluations == 8
    (whole,) = run_many(problem, [Lane(problem, Down(OptimizerParams(), problem.bounds,
                                                     np.random.default_rng(0)), 12)])
    assert whole.stopped_by == "budget" and whole.evaluations == 12 and whole.f_best == 4.0


def test_an_archive_of_optima_alone_certifies_without_adding_runs(archives, tmp_path):
    """An optima-only archive (what the paper's problem ships): target= stops at its optima,
    and a report beside it gains no archived runs."""
    from vpid_bench.report.build import build_report

    only = tmp_path / "only"
    manifest = pack(archives.parent / "base", "paper", only / "paper", command="test",
                         commit=None, made_at="2026-01-01T00:00:00+00:00", optima_only=True)
    assert manifest["runs"] == 0 and manifest["optima_only"] is True
    read = read_archive(only / "paper")
    assert read.records == [] and len(read.optima) >= 3
    done, out = _job(tmp_path, only, "runs=3", "target=0.5")
    assert done.returncode == 0, done.stderr[-2000:]
    assert {r["result"]["stopped_by"] for r in _records(out).values()} == {"target"}
    report = build_report([out], tmp_path / "report", short=True, archive=only)
    assert report.archive_notes == [] and report.n_records == 3
