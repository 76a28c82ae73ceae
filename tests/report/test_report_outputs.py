"""The report's files: every figure drawn and not empty, tables, merging sweeps, bad
records, the CLI's exit codes and the Hydra callback."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from extras import limit
from report_synth import OV, PAPER_NAMES, objective_job, record, write_job

from vpid_bench.api import Bounds, Problem, ProblemConfig
from vpid_bench.report.build import NoRecordsError, build_report
from vpid_bench.report.cli import main as report_main
from vpid_bench.report.load import load_records, run_rows
from vpid_bench.store.artifacts import best_of, write_best_signals
from vpid_bench.store.records import read_record


@dataclasses.dataclass(frozen=True)
class FakeConfig(ProblemConfig):
    """The config keys the synthetic records carry."""


class FakeVehicle(Problem):
    """Nine parameters and two signal channels; the fitted signal is scaled by x[0]/OV[0]."""

    Config = FakeConfig

    @property
    def bounds(self) -> Bounds:
        return Bounds(0.5 * OV, 1.5 * OV, tuple(PAPER_NAMES))

    def evaluate(self, X):
        return np.zeros(len(X))

    def signal_units(self):
        return {"z1''": "m/s²", "z2''": "m/s²"}

    def signals(self, x):
        t = np.linspace(0.0, 0.48, 100)
        ref = np.sin(20 * t)
        out = {"t": t}
        for ch in ("z1''", "z2''"):
            out[f"{ch}:measured"] = ref
            out[f"{ch}:fitted"] = ref * x[0] / OV[0]
        return out


def _vehicle_sweep(root: Path) -> Path:
    rng = np.random.default_rng(0)
    for ps in (20, 30):
        for algo, spread in (("de4", 0.01), ("de1", 0.05), ("random", 0.3)):
            recs = [record(problem="vehicle", optimizer=algo, ps=ps, run_index=i,
                           x=OV * (1 + spread * rng.standard_normal(9)), f=spread * (1 + i),
                           names=PAPER_NAMES, true=OV, info={"f_at_true": 0.004})
                    for i in range(6)]
            job = write_job(root / f"optimizer={algo},problem.ps={ps}", recs)
            paths = sorted((job / "records").glob("run-*.json"))
            x, source = best_of([read_record(p) for p in paths])
            write_best_signals(job, FakeVehicle(FakeConfig()), x, source)
    return root


@pytest.fixture(scope="module")
def vehicle_report(tmp_path_factory):
    root = _vehicle_sweep(tmp_path_factory.mktemp("sweep"))
    return build_report([root], root / "report")


def _png_ok(path: Path) -> bool:
    import matplotlib.image as mpimg

    img = mpimg.imread(path)
    return img.ndim == 3 and min(img.shape[:2]) > 100 and float(img[..., :3].std()) > 0.01


def test_every_figure_is_drawn_and_not_empty(vehicle_report):
    figs = vehicle_report.out_dir / "figures"
    expected = ["convergence.png", "runs_vehicle.png", "errors_vehicle.png",
                "signals_vehicle.png", "cd_vehicle_ps=20.png", "cd_vehicle_ps=30.png"]
    for name in expected:
        assert (figs / name).is_file(), name
        assert _png_ok(figs / name), name
    # Two blocks are too few for a meaningful Friedman CD diagram: not drawn, and said so.
    assert not (figs / "cd_blocks.png").exists()
    assert "at least 5 blocks" in vehicle_report.skipped_figures[
        "Critical-difference diagram across blocks"]
    assert len(vehicle_report.skipped_figures) == 1
    md = vehicle_report.report_md.read_text()
    for name in expected:
        assert f"(figures/{name})" in md


def test_report_lines_fit_in_120_columns(vehicle_report):
    md = vehicle_report.report_md.read_text()
    wide = [ln for ln in md.splitlines() if len(ln) > 120]
    assert wide == []
    assert "- Table" not in md  # no stray bullets after tables


def test_tables_and_tidy_runs(vehicle_report):
    import pandas as pd

    runs = pd.read_csv(vehicle_report.out_dir / "runs.csv")
    assert len(runs) == 36 and set(runs.metric_name) == {"NoRE"}
    assert "metric.NoRE" in runs.columns and "nore" not in runs.columns
    t = vehicle_report.out_dir / "tables"
    for stem in ("headline", "run_stats", "mean_vector", "kruskal", "pairwise"):
        assert (t / f"{stem}.csv").is_file()
        tex = (t / f"{stem}.tex").read_text()
        assert "\\toprule" in tex and "\\bottomrule" in tex
    head = vehicle_report.headline
    assert "de4" in head and "baseline" in head
    # de4 (1 % scatter) ranks first in both contexts, random (30 %) last.
    st = pd.read_csv(t / "run_stats.csv")
    for _, g in st.groupby("context"):
        assert list(g.sort_values("rank").algorithm) == ["de4", "de1", "random"]
    assert vehicle_report.failures == []


def test_convergence_has_a_log_axis_and_the_truth_line(tmp_path):
    from vpid_bench.report import figures
    from vpid_bench.report.identifiability import reference_levels
    from vpid_bench.report.load import trace_sets

    root = tmp_path / "s"
    for algo in ("a", "b"):
        recs = [record(problem="toy", optimizer=algo, ps=10, run_index=i, x=np.ones(2),
                       f=0.1 * (i + 1), names=["x1", "x2"], true=None,
                       info={"f_at_true": 0.05}) for i in range(3)]
        write_job(root / algo, recs)
    loaded = load_records([root])
    rows = run_rows(loaded.records)
    ft, _ = reference_levels(loaded.records, rows)  # what the report draws
    assert ft == {"toy ps=10": 0.05}
    import matplotlib.pyplot as plt

    seen = {}
    original = plt.Figure.savefig

    def spy(fig, *args, **kwargs):
        ax = fig.axes[0]
        seen["scale"] = ax.get_yscale()
        seen["lines"] = [tuple(ln.get_ydata()) for ln in ax.lines if ln.get_linestyle() == "--"]
        return original(fig, *args, **kwargs)

    plt.Figure.savefig = spy
    try:
        out = figures.draw_convergence(  # the report's path: plain traces -> panels -> figure
            figures.convergence_panels(trace_sets(loaded.records, rows), ft), tmp_path / "c.png")
    finally:
        plt.Figure.savefig = original
    assert out == tmp_path / "c.png"
    assert seen["scale"] == "log" and seen["lines"] == [(0.05, 0.05)]


def test_signals_legend_stays_off_the_rear_axle_response():
    """The legend does not cover any data point of the last 18 ms in any panel."""
    from vpid_bench.report.signals import draw_signals

    t = np.linspace(0.0, 0.48, 481)
    rear = np.where(t > 0.462, 400 * (t - 0.462), 0.0)
    channels = {"z1''": (np.sin(30 * t), 0.9 * np.sin(30 * t)), "z2''": (rear, 0.95 * rear)}
    fig = draw_signals(t, channels, {"z1''": "m/s²", "z2''": "m/s²"}, "test")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    (legend,) = fig.legends
    box = legend.get_window_extent(renderer)
    late = t >= t[-1] - 0.018
    for ax in fig.axes:
        for line in ax.lines:
            x, y = line.get_xdata(), line.get_ydata()
            if len(x) != len(t):
                continue
            pts = ax.transData.transform(np.column_stack([x[late], y[late]]))
            inside = ((pts[:, 0] >= box.x0) & (pts[:, 0] <= box.x1)
                      & (pts[:, 1] >= box.y0) & (pts[:, 1] <= box.y1))
            assert not inside.any()
    labels = [tx.get_text() for tx in legend.get_texts()]
    assert labels == ["measured", "fitted", "residual (measured − fitted)"]
    assert len(fig.axes) == 4  # a residual panel under each channel
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_merge_two_sweeps_and_duplicates(tmp_path):
    a = objective_job(tmp_path / "sweep_a", "good", 20, [1.0, 1.1, 1.2]).parent
    b = objective_job(tmp_path / "sweep_b", "bad", 20, [3.0, 3.1, 3.2]).parent
    rep = build_report([a, b, a], tmp_path / "out", short=True)
    assert rep.n_records == 6
    assert "good" in rep.headline and "bad" in rep.headline
    assert rep.loaded.duplicates == 0  # the same folder twice is read once


def test_bad_record_is_listed_not_fatal(tmp_path):
    job = objective_job(tmp_path, "a", 20, [1.0, 2.0])
    (job / "records" / "run-009-deadbeef.json").write_text("{ not json")
    failed = record(problem="toy", optimizer="a", ps=20, run_index=5, x=None, f=None,
                    names=["x1", "x2"], true=None, status="failed")
    write_job(tmp_path / "failed-job", [failed], status="failed_runs")
    rep = build_report([tmp_path], tmp_path / "out", short=True)
    assert rep.n_records == 3
    text = " ".join(rep.failures)
    assert "run-009-deadbeef.json" in text and "failed_runs" in text
    md = rep.report_md.read_text()
    assert "Skipped unreadable record" in md and "Failed run" in md


def test_no_records(tmp_path):
    with pytest.raises(NoRecordsError):
        build_report([tmp_path], tmp_path / "out")


def test_cli_exit_codes(tmp_path, capsys):
    assert report_main([str(tmp_path)]) == 2
    assert "no run records" in capsys.readouterr().err
    assert report_main([str(tmp_path / "missing")]) == 2
    objective_job(tmp_path / "s", "a", 20, [1.0, 2.0])
    out = tmp_path / "rep"
    assert report_main([str(tmp_path / "s"), "-o", str(out), "--short"]) == 0
    assert (out / "report.md").is_file()
    assert report_main([str(tmp_path / "s"), "--alpha", "2"]) == 2
    capsys.readouterr()
    # A torn record: the report is written from the others, exit 1, one line names the file.
    torn = tmp_path / "s" / "optimizer=a,ps=20,seed=0" / "records" / "run-009-torn.json"
    torn.write_text('{"schema": "vpid')
    assert report_main([str(tmp_path / "s"), "-o", str(out), "--short"]) == 1
    captured = capsys.readouterr()
    (line,) = [ln for ln in captured.err.splitlines() if torn.name in ln]
    assert line == (f"warning: unreadable record {torn}: not a readable JSON run record "
                    "(Unterminated string starting at: line 1 column 12 (char 11))")
    assert "(2 run records)" in captured.out and (out / "report.md").is_file()


@pytest.mark.slow  # the default run's twin: test_html_browser's README sweep (same callback)
def test_real_sweep_ends_with_a_report(tmp_path):
    """`vpid-bench -m ...` end to end: the callback writes the report into the sweep dir."""
    exe = Path(sys.executable).with_name("vpid-bench")
    sweep = tmp_path / "sweep"
    out = subprocess.run(
        [str(exe), "-m", "problem=functions", "optimizer=random,de1", "runs=3",
         "problem.iterations=3", "problem.dim=3", "progress=false", f"hydra.sweep.dir={sweep}"],
        capture_output=True, text=True, timeout=limit(300),
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert (sweep / "report" / "report.md").is_file()
    assert "random" in out.stdout and "baseline" in out.stdout


def test_ctrl_c_during_the_report_is_one_line_and_status_130(tmp_path, monkeypatch, capsys):
    """SIGINT during vpid-bench-report once printed a traceback."""
    from vpid_bench.report import build
    from vpid_bench.report.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(build, "build_report", interrupted)
    (tmp_path / "sweep").mkdir()
    assert main([str(tmp_path / "sweep"), "-o", str(tmp_path / "out")]) == 130
    err = capsys.readouterr().err
    assert err.strip() == ("interrupted: no report written (its folder keeps the previous one, "
                           "if any); run the same command again")
