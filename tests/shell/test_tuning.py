"""A job returns its search score, so Hydra's Optuna sweeper can tune an optimizer on it."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from extras import needs  # noqa: E402
from sweep_helpers import run_cli  # noqa: E402

from vpid_bench.analysis.optimum import find_optimum, load_optima  # noqa: E402
from vpid_bench.experiment import run_from_config  # noqa: E402


def test_the_score_is_the_median_relative_gap_to_each_instances_optimum(compose_config,
                                                                        registry, tmp_path):
    cfg = compose_config(["optimizer=de1", "problem.iterations=3", "runs=3", "progress=false"])
    summary = run_from_config(cfg, tmp_path / "job", registry)
    records = [json.loads(p.read_text()) for p in summary.record_paths]
    optima = load_optima([tmp_path / "job" / "optima"])
    assert len(optima) == 3  # one noise record per run (problem.noise.per_run=true)
    gaps = []
    for record in records:
        f_opt = find_optimum(record, optima)["f_opt"]
        gaps.append((record["result"]["f_best"] - f_opt) / f_opt)
    assert min(gaps) >= 0  # the polish never ends above a run's best
    assert summary.score == pytest.approx(float(np.median(gaps)), rel=1e-12)


def test_without_an_optimum_the_score_is_the_median_best_objective(compose_config, registry,
                                                                   tmp_path):
    cfg = compose_config(["problem=functions", "optimizer=random", "problem.iterations=2",
                          "runs=3", "progress=false"])
    summary = run_from_config(cfg, tmp_path / "job", registry)
    f_best = [json.loads(p.read_text())["result"]["f_best"] for p in summary.record_paths]
    assert summary.score == pytest.approx(float(np.median(f_best)))


@needs("hydra_plugins.hydra_optuna_sweeper", "tune")
def test_optuna_tunes_a_de_on_the_returned_score(tmp_path):
    done = run_cli(["-m", "hydra/sweeper=optuna", "hydra.sweeper.n_trials=2",
                    "problem=functions", "problem.dim=3", "optimizer=de1",
                    "optimizer.F=interval(0.3,1.0)", "problem.iterations=3", "runs=2",
                    "progress=false", "report=false", f"hydra.sweep.dir={tmp_path}/tune"],
                   tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Best value:" in done.stdout + done.stderr
    assert len(list((tmp_path / "tune").glob("*/job.json"))) == 2
