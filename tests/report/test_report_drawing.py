"""The report's figures: the core's drawn in the report's process, one that fails costs that
figure only, a plugin section's figure is drawn with save_figure (a section whose figure fails
costs that section only, and says so), step curves thinned without losing a step, and the
numpy Holm and Nemenyi against the libraries they replace."""

from __future__ import annotations

import types
from pathlib import Path

import numpy as np
import pytest
from report_synth import objective_job
from test_report_outputs import _vehicle_sweep

from vpid_bench import hookimpl
from vpid_bench.report import figures, stats
from vpid_bench.report.build import build_report
from vpid_bench.report.sections import Contribution, Section


def _png_ok(path: Path) -> bool:
    import matplotlib.image as mpimg

    img = mpimg.imread(path)
    return img.ndim == 3 and min(img.shape[:2]) > 100 and float(img[..., :3].std()) > 0.01


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    return _vehicle_sweep(tmp_path_factory.mktemp("sweep"))


def test_the_core_figures_and_the_signals_figure_are_drawn(sweep, tmp_path):
    rep = build_report([sweep], tmp_path / "out")
    pngs = sorted(p.relative_to(rep.out_dir).as_posix()
                  for p in rep.out_dir.rglob("*.png"))
    assert {"figures/cd_vehicle_ps=20.png", "figures/cd_vehicle_ps=30.png",
            "figures/convergence.png", "figures/errors_vehicle.png",
            "figures/runs_vehicle.png", "figures/signals_vehicle.png"} <= set(pngs)
    for f in pngs:
        assert _png_ok(rep.out_dir / f), f
    md = rep.report_md.read_text()
    assert "## Measured vs fitted signals of the best run" in md


def test_a_raising_core_figure_costs_that_figure_only(sweep, tmp_path, monkeypatch):
    def explode(*args, **kwargs):
        raise ValueError("this figure exploded")

    monkeypatch.setattr(figures, "draw_error_heatmap", explode)
    rep = build_report([sweep], tmp_path / "out")
    title = "Median per-run absolute relative error per parameter, vehicle"
    assert rep.skipped_figures[title] == "failed: ValueError: this figure exploded"
    assert not (tmp_path / "out" / "figures" / "errors_vehicle.png").exists()
    assert _png_ok(tmp_path / "out" / "figures" / "convergence.png")
    assert "this figure exploded" in " ".join(rep.report_md.read_text().split())


def _raising_plugin_figure(n: int):
    raise RuntimeError(f"plugin figure {n} exploded")


def _plugin_line(values: list[float]):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot(values)
    return fig


def _figure_plugin() -> types.SimpleNamespace:
    def good(ctx):
        png = ctx.save_figure(_plugin_line([1.0, 2.0, 0.5]), "good line")
        return Contribution(sections=(Section("Figures of a plugin", "text", (png,)),))

    def bad(ctx):
        png = ctx.save_figure(_raising_plugin_figure(7), "bad line")
        return Contribution(sections=(Section("A failing plugin", "text", (png,)),))

    @hookimpl
    def vpid_bench_register_report_sections(register):
        register("toy", good)
        register("toy", bad)

    return types.SimpleNamespace(
        vpid_bench_register_report_sections=vpid_bench_register_report_sections)


def test_a_plugin_figure_that_fails_costs_its_section_and_is_reported(tmp_path, registry_of):
    objective_job(tmp_path / "s", "a", 10, [1.0, 2.0, 3.0, 4.0, 5.0])
    objective_job(tmp_path / "s", "b", 10, [2.0, 3.0, 4.0, 5.0, 6.0])
    registry = registry_of(("figplug", _figure_plugin()))
    rep = build_report([tmp_path / "s"], tmp_path / "out", registry=registry)
    figs = tmp_path / "out" / "figures"
    assert _png_ok(figs / "good_line.png")
    assert not (figs / "bad_line.png").exists()
    md = rep.report_md.read_text()
    assert "(figures/good_line.png)" in md and "A failing plugin" not in md.split("Not built")[0]
    (line,) = [e for e in rep.section_errors if "exploded" in e]
    assert "figplug" in line and "RuntimeError: plugin figure 7 exploded" in line
    assert "Convergence" not in rep.skipped_figures  # the core figures are unaffected


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


@pytest.mark.parametrize("n", [1, 10, 12, 25])
def test_every_curve_gets_a_colour_of_its_own(n):
    """The 10× study draws 12 optimizers: the colours stay distinct past the 10 of the
    colour cycle (the cycle's own colours up to 10, as before)."""
    import matplotlib.colors as mcolors

    got = [mcolors.to_hex(c) for c in figures.colours(n)]
    assert len(got) == n and len(set(got)) == n
    if n <= 10:
        assert got == [mcolors.to_hex(f"C{i}") for i in range(n)]


def test_nan_column_quantiles_are_numpys_nanquantile():
    """The convergence figure's quartiles per evaluation count: numpy's ``nanquantile`` along
    an axis loops over the columns in Python (minutes for an archive's report); the grouped
    version gives the same numbers, bit for bit, with NaN prefixes of any length."""
    import warnings

    from vpid_bench.report.figures import nan_column_quantiles

    rng = np.random.default_rng(0)
    for _ in range(100):
        rows, cols = rng.integers(1, 40), rng.integers(1, 200)
        m = rng.lognormal(size=(rows, cols)) * rng.choice([1e-3, 1.0, 1e3])
        m[rng.random((rows, cols)) < rng.random()] = np.nan
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN column
            expected = np.nanquantile(m, [0.25, 0.5, 0.75], axis=0)
        np.testing.assert_array_equal(nan_column_quantiles(m, [0.25, 0.5, 0.75]), expected)
