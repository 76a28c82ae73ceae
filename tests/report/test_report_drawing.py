"""The report's figures drawn in worker processes: the same files as drawn serially, a
failing figure costs that figure only, no worker outlives a report (nor an interrupted one),
step curves thinned without losing a step, and the numpy Holm and Nemenyi against the
libraries they replace."""

from __future__ import annotations

import multiprocessing
import os
import time
import types
from pathlib import Path

import numpy as np
import pytest
from report_synth import objective_job
from test_report_outputs import _vehicle_sweep

from vpid_bench import hookimpl
from vpid_bench.report import figures, stats
from vpid_bench.report.build import build_report
from vpid_bench.report.drawing import FigureDrawer
from vpid_bench.report.sections import Contribution, Section


def _children() -> list[int]:
    """Processes whose parent is this one (Linux /proc), plus multiprocessing's own list,
    without multiprocessing's resource tracker: one helper per interpreter, started with
    the first spawned process and ending with this process, not a figure worker."""
    from multiprocessing import resource_tracker

    me = os.getpid()
    found = {p.pid for p in multiprocessing.active_children()}
    proc = Path("/proc")
    if proc.is_dir():
        for d in proc.iterdir():
            if not d.name.isdigit():
                continue
            try:
                status = (d / "status").read_text()
            except OSError:
                continue
            for line in status.splitlines():
                if line.startswith("PPid:") and int(line.split()[1]) == me:
                    found.add(int(d.name))
    found.discard(getattr(resource_tracker._resource_tracker, "_pid", None))
    return sorted(found)


def _no_children(grace_s: float = 5.0) -> bool:
    """Whether :func:`_children` is empty, allowing a terminated worker ``grace_s`` seconds
    to be reaped (a process that is exiting still shows in /proc for a moment)."""
    deadline = time.monotonic() + grace_s
    while _children():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


def _png_ok(path: Path) -> bool:
    import matplotlib.image as mpimg

    img = mpimg.imread(path)
    return img.ndim == 3 and min(img.shape[:2]) > 100 and float(img[..., :3].std()) > 0.01


def _md(path: Path) -> list[str]:
    return [ln for ln in path.read_text().splitlines() if not ln.startswith("Built ")]


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    return _vehicle_sweep(tmp_path_factory.mktemp("sweep"))


def test_parallel_and_serial_write_the_same_report(sweep, tmp_path):
    assert _no_children()
    par = build_report([sweep], tmp_path / "par", figures="parallel", workers=2)
    assert par.figures_mode == "parallel (2 workers)"
    assert _no_children()  # every worker stopped with the report
    ser = build_report([sweep], tmp_path / "ser", figures="serial")
    assert ser.figures_mode == "serial"

    def files(root: Path) -> list[str]:
        return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())

    assert files(par.out_dir) == files(ser.out_dir)
    pngs = [f for f in files(par.out_dir) if f.endswith(".png")]
    assert pngs == ["figures/cd_vehicle_ps=20.png", "figures/cd_vehicle_ps=30.png",
                    "figures/convergence.png", "figures/errors_vehicle.png",
                    "figures/runs_vehicle.png", "figures/signals_vehicle.png"]  # + a plugin's
    for f in pngs:
        assert _png_ok(par.out_dir / f) and _png_ok(ser.out_dir / f), f
    assert _md(par.report_md) == _md(ser.report_md)
    assert par.skipped_figures == ser.skipped_figures
    for f in files(par.out_dir):
        if f.startswith("tables/") or f == "runs.csv":
            assert (par.out_dir / f).read_bytes() == (ser.out_dir / f).read_bytes(), f


def _ok_figure(path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    return figures.save(fig, path)


def _raising_figure(path: Path) -> Path:
    raise ValueError("this figure exploded")


def _dies_in_a_worker(path: Path) -> Path:
    """Kills the worker process that draws it (as the OOM killer would); draws when called
    in the report's own process."""
    if multiprocessing.parent_process() is not None:
        os._exit(3)
    return _ok_figure(path)


def _raising_plugin_figure(n: int):
    raise RuntimeError(f"plugin figure {n} exploded")


def _plugin_line(values: list[float]):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot(values)
    return fig


@pytest.mark.parametrize("mode", ["parallel", "serial"])
def test_a_raising_figure_costs_that_figure_only(tmp_path, mode):
    with FigureDrawer(mode, workers=2) as drawer:
        drawer.submit("ok", _ok_figure, tmp_path / "ok.png")
        drawer.submit("bad", _raising_figure, tmp_path / "bad.png")
        drawer.submit("ok2", _ok_figure, tmp_path / "ok2.png")
        out = drawer.results()
    assert list(out) == ["ok", "bad", "ok2"]
    assert out["ok"] == tmp_path / "ok.png" and _png_ok(out["ok"])
    assert out["ok2"] == tmp_path / "ok2.png" and _png_ok(out["ok2"])
    assert out["bad"] == "failed: ValueError: this figure exploded"
    assert not (tmp_path / "bad.png").exists()
    assert _no_children()


def test_figures_of_a_dead_worker_are_drawn_here(tmp_path):
    with FigureDrawer("parallel", workers=2) as drawer:
        drawer.submit("dies", _dies_in_a_worker, tmp_path / "dies.png")
        drawer.submit("ok", _ok_figure, tmp_path / "ok.png")
        out = drawer.results()
    assert out == {"dies": tmp_path / "dies.png", "ok": tmp_path / "ok.png"}
    assert _png_ok(out["dies"]) and _png_ok(out["ok"])
    assert _no_children()


def _figure_plugin() -> types.SimpleNamespace:
    def section(ctx):
        good = ctx.draw_figure(_plugin_line, "good line", [1.0, 2.0, 0.5])
        bad = ctx.draw_figure(_raising_plugin_figure, "bad line", 7)
        return Contribution(sections=(Section("Figures of a plugin", "text", (good, bad)),))

    @hookimpl
    def vpid_bench_register_report_sections(register):
        register("toy", section)

    return types.SimpleNamespace(
        vpid_bench_register_report_sections=vpid_bench_register_report_sections)


@pytest.mark.parametrize("mode", ["parallel", "serial"])
def test_a_plugin_figure_that_fails_is_dropped_and_reported(tmp_path, mode, registry_of):
    objective_job(tmp_path / "s", "a", 10, [1.0, 2.0, 3.0, 4.0, 5.0])
    objective_job(tmp_path / "s", "b", 10, [2.0, 3.0, 4.0, 5.0, 6.0])
    registry = registry_of(("figplug", _figure_plugin()))
    rep = build_report([tmp_path / "s"], tmp_path / "out", registry=registry, figures=mode,
                       workers=2)
    figs = tmp_path / "out" / "figures"
    assert _png_ok(figs / "good_line.png")
    assert not (figs / "bad_line.png").exists()
    md = rep.report_md.read_text()
    assert "(figures/good_line.png)" in md and "bad_line.png)" not in md
    (line,) = [e for e in rep.section_errors if "bad_line.png" in e]
    assert "figplug" in line and "RuntimeError: plugin figure 7 exploded" in line
    assert "Convergence" not in rep.skipped_figures  # the core figures are unaffected
    assert _no_children()


def _interrupting_plugin() -> types.SimpleNamespace:
    def section(ctx):
        ctx.draw_figure(_plugin_line, "queued line", [1.0, 2.0])
        raise KeyboardInterrupt  # as if the user pressed Ctrl-C while the workers draw

    @hookimpl
    def vpid_bench_register_report_sections(register):
        register("toy", section)

    return types.SimpleNamespace(
        vpid_bench_register_report_sections=vpid_bench_register_report_sections)


def test_no_worker_is_left_after_an_interrupt(tmp_path, registry_of):
    objective_job(tmp_path / "s", "a", 10, [1.0, 2.0, 3.0, 4.0, 5.0])
    objective_job(tmp_path / "s", "b", 10, [2.0, 3.0, 4.0, 5.0, 6.0])
    registry = registry_of(("irq", _interrupting_plugin()))
    with pytest.raises(KeyboardInterrupt):
        build_report([tmp_path / "s"], tmp_path / "out", registry=registry,
                     figures="parallel", workers=2)
    assert _no_children()


def test_the_drawer_kills_its_workers_on_an_error_in_the_block(tmp_path):
    with (pytest.raises(RuntimeError, match="main process failed"),
          FigureDrawer("parallel", workers=2) as drawer):
        drawer.submit("ok", _ok_figure, tmp_path / "ok.png")
        assert len(_children()) >= 1  # the workers were started at once
        raise RuntimeError("main process failed")
    assert _no_children()


def test_figure_modes_are_checked():
    with pytest.raises(ValueError, match="auto, parallel, serial"):
        FigureDrawer("threads")  # type: ignore[arg-type]
    assert FigureDrawer("auto", workers=0).mode == "serial"  # a single core: serial


# --- thinning of step curves ----------------------------------------------------------------

def _value_at(x: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    """A steps-post curve's value at ``at`` (NaN before its first point)."""
    return figures.step_values(x, y, at)


def test_thinning_drops_only_points_where_nothing_changes():
    # A best-so-far trace: 3000 batches of 7 evaluations, improving at 40 of them.
    ev = 7.0 * np.arange(1, 3001)
    rng = np.random.default_rng(3)
    steps = np.sort(rng.choice(ev.size, 40, replace=False))
    best = np.full(ev.size, 10.0)
    for k, i in enumerate(steps):
        best[i:] = 10.0 * 0.8 ** (k + 1)
    x, y = figures.thin_steps(ev, best, max_points=400)
    assert 40 <= x.size <= 42  # the 40 corners, the first and the last point
    assert x[0] == ev[0] and x[-1] == ev[-1]
    # Exact: the thinned curve equals the original at every original evaluation count.
    np.testing.assert_array_equal(_value_at(x, y, ev), best)


def test_thinning_many_steps_stays_within_one_bin():
    # Every batch improves: 5000 distinct steps, thinned to 300 points.
    ev = np.cumsum(np.random.default_rng(1).integers(1, 20, 5000)).astype(float)
    best = 1.0 / np.arange(1, ev.size + 1)
    x, lo, hi = figures.thin_steps(ev, best, 2 * best, max_points=300)
    assert x.size <= 300 and x[0] == ev[0] and x[-1] == ev[-1]
    # Exact at the kept points ...
    kept = np.searchsorted(ev, x)
    np.testing.assert_array_equal(lo, best[kept])
    np.testing.assert_array_equal(hi, 2 * best[kept])
    # ... and in between, the value of the original at most one bin width earlier: for a
    # non-increasing trace, between the original's value at e - w and at e.
    w = (ev[-1] - ev[0]) / 299
    thinned = _value_at(x, lo, ev)
    earlier = _value_at(ev, best, np.maximum(ev - w, ev[0]))
    assert np.all(thinned <= earlier) and np.all(thinned >= best)


def test_convergence_panels_quartiles_match_a_hand_computation():
    # Two runs of one optimizer, batches of 10 and 15 evaluations: the common grid is the
    # union of their counts and each run holds its value between its own batches.
    traces = {"c": {"a": [(np.array([10.0, 20.0, 30.0]), np.array([5.0, 3.0, 1.0])),
                          (np.array([15.0, 30.0]), np.array([4.0, 2.0]))]}}
    (panel,) = figures.convergence_panels(traces)
    (curve,) = panel["curves"]
    # grid 10, 15, 20, 30: run 1 = 5, 5, 3, 1; run 2 = nan, 4, 4, 2
    np.testing.assert_array_equal(curve["x"], [10.0, 15.0, 20.0, 30.0])
    np.testing.assert_allclose(curve["median"], [5.0, 4.5, 3.5, 1.5])
    np.testing.assert_allclose(curve["q25"], [5.0, 4.25, 3.25, 1.25])
    assert panel["runs"] == [2]


# --- the statistics that replaced library calls ---------------------------------------------

def test_holm_matches_statsmodels():
    from statsmodels.stats.multitest import multipletests

    rng = np.random.default_rng(7)
    for n in (1, 2, 5, 36):
        p = rng.uniform(0, 0.2, n)
        p[rng.integers(0, n)] = p[0]  # a tie
        np.testing.assert_allclose(stats.holm(p.tolist()), multipletests(p, method="holm")[1],
                                   rtol=0, atol=1e-15)
    got = stats.holm([0.01, float("nan"), 0.04, 0.03])
    assert np.isnan(got[1])
    np.testing.assert_allclose([got[0], got[2], got[3]],
                               multipletests([0.01, 0.04, 0.03], method="holm")[1])
    assert stats.holm([]) == []


def test_nemenyi_matches_scikit_posthocs():
    sp = pytest.importorskip("scikit_posthocs")
    rng = np.random.default_rng(11)
    for n, k in ((6, 3), (30, 9), (12, 5)):
        values = rng.normal(size=(n, k)) + np.arange(k) * 0.3
        values[0, 1] = values[0, 2]  # a tie within a block
        np.testing.assert_allclose(stats.nemenyi_friedman(values),
                                   sp.posthoc_nemenyi_friedman(values).to_numpy(),
                                   rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("seed", range(12))
def test_cd_bars_are_the_maximal_groups_scikit_posthocs_draws(seed):
    """The CD diagram's bars (from the compact letter display) are the maximal cliques of the
    'not significantly different' graph, as scikit-posthocs' own diagram computes them."""
    sp_plotting = pytest.importorskip("scikit_posthocs._plotting")
    import pandas as pd

    from vpid_bench.report.figures import cd_bars

    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 9))
    names = [f"o{i}" for i in range(k)]
    p = rng.choice([0.001, 0.01, 0.2, 0.6], size=(k, k), p=[0.3, 0.2, 0.3, 0.2])
    p = np.triu(p, 1) + np.triu(p, 1).T + np.eye(k)
    same = pd.DataFrame(p >= 0.05, index=names, columns=names)
    expected = {frozenset(c) for c in sp_plotting._find_maximal_cliques(same) if len(c) > 1}
    bars = cd_bars(names, p, 0.05)
    assert {frozenset(b) for b in bars} == expected
    assert all(b == sorted(b, key=names.index) for b in bars)  # best first within a bar


@pytest.mark.parametrize(
    ("file", "spec", "safe"),
    [
        (None, None, True),  # interactive, python -c, a notebook
        ("/some/where/vpid-bench-report", None, True),  # our console scripts guard main()
        ("/home/me/my_analysis.py", None, False),  # a user's script: may be unguarded
        ("/x/pytest/__main__.py", "pytest.__main__", True),  # python -m: imported by name
    ],
)
def test_auto_uses_workers_only_when_the_main_module_is_safe_to_import(
        monkeypatch, file, spec, safe):
    """A spawned worker imports the main module: an unguarded script would run again in
    every worker, so "auto" draws serially for a script it does not know."""
    import sys
    import types

    from vpid_bench.report import drawing

    main = types.ModuleType("__main__")
    if file is not None:
        main.__file__ = file
    main.__spec__ = types.SimpleNamespace(name=spec) if spec else None
    monkeypatch.setitem(sys.modules, "__main__", main)
    assert drawing.main_is_safe() is safe
    with drawing.FigureDrawer("auto", workers=2) as auto:
        assert auto.mode == ("parallel" if safe else "serial")
    explicit = drawing.FigureDrawer("parallel", workers=1)  # the caller's choice, guarded
    assert explicit.mode == "parallel"
    explicit.terminate()
