"""One style per optimizer (report/styles.py): up to 20 optimizers (and more) keep distinct
(colour, dash, marker) styles, the same in every figure of a report, and the ECDF legend
shows every line distinguishably (issue 46, item 3)."""

from __future__ import annotations

import math

import pytest

from vpid_bench.report import anytime, figures, styles, svg
from vpid_bench.report.anytime import RunHits
from vpid_bench.report.interactive import ecdf_figure

NAMES = [f"opt{k:02d}" for k in range(20)]


def test_twenty_names_get_twenty_distinct_styles():
    got = styles.assign(NAMES)
    assert len({(s.colour, s.dash, s.marker) for s in got.values()}) == 20
    # colour and dashes alone tell 40 apart; no colour shares its marker below 70
    many = styles.assign(f"o{k:03d}" for k in range(70))
    assert len({(s.colour, s.dash) for s in list(many.values())[:40]}) == 40
    assert len({(s.colour, s.marker) for s in many.values()}) == 70
    assert set(styles.PALETTE) == {s.colour for s in got.values()}


def test_a_name_keeps_its_style_in_a_figure_of_fewer_optimizers():
    report = styles.assign(NAMES)
    subset = styles.lookup(report, ["opt13", "opt02"])
    assert subset["opt13"] == report["opt13"] and subset["opt02"] == report["opt02"]
    # a figure drawn outside a report numbers its own optimizers
    alone = styles.lookup(None, ["opt13"])
    assert alone["opt13"] == styles.style(0)


def test_every_marker_has_its_own_svg_shape():
    shapes = {m: svg.marker_path(m, 10.0, 10.0) for m in styles.MARKERS}
    assert len(set(shapes.values())) == len(styles.MARKERS)
    assert all(p.startswith("M") and p.endswith("Z") for p in shapes.values())


def _hits(n: int) -> list[RunHits]:
    """``n`` optimizers, two runs each, reaching the targets at spread evaluations."""
    return [RunHits("ctx", name, 1000.0, 1000.0,
                    tuple(float(10 + 30 * k + 5 * t + r) for t in range(6)) + (math.nan,))
            for k, name in enumerate(NAMES[:n]) for r in range(2)]


def test_the_ecdf_legend_shows_every_line_distinguishably(monkeypatch, tmp_path):
    """The PNG ECDF of 20 optimizers: 20 legend entries, each with its own colour, dashes
    and marker, the same as its line's; the legend sits beside the axes, hiding no curve."""
    caught = {}

    def keep(fig, path):
        caught["fig"] = fig
        fig.canvas.draw()
        return path

    monkeypatch.setattr(figures, "save", keep)
    anytime.ecdf_figure(_hits(20), "ctx", tmp_path / "e.png", styles.assign(NAMES))
    fig = caught["fig"]
    ax = fig.axes[0]
    legend = ax.get_legend()
    import matplotlib.colors as mcolors

    def key(line):
        return mcolors.to_hex(line.get_color()), line.get_linestyle(), line.get_marker()

    entries = legend.legend_handles
    assert len(entries) == 20
    shown = {t.get_text().split(" ")[0]: key(h)
             for t, h in zip(legend.get_texts(), entries, strict=True)}
    assert len(set(shown.values())) == 20
    assert shown["opt00"][0] == shown["opt10"][0] and shown["opt00"][1] != shown["opt10"][1]
    lines = {ln.get_label().split(" ")[0]: ln for ln in ax.get_lines()}
    for text, handle in zip(legend.get_texts(), entries, strict=True):
        line = lines[text.get_text().split(" ")[0]]
        assert mcolors.to_hex(handle.get_color()) == mcolors.to_hex(line.get_color())
        assert handle.get_marker() == line.get_marker()
        assert handle.get_linestyle() == line.get_linestyle()
    renderer = fig.canvas.get_renderer()
    assert legend.get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_the_svg_ecdf_gives_every_series_and_its_key_the_report_style():
    fig = ecdf_figure(_hits(20), "ctx")
    report = styles.assign(["aaa", *NAMES])  # a report with one more optimizer
    lay = svg.layout(fig, report)
    assert len({(s.colour, s.dasharray, s.marker) for s in lay.series}) == 20
    for s in lay.series:
        st = report[s.name]
        assert (s.colour, s.marker) == (st.colour, st.marker)
        assert s.dasharray == svg.dasharray(st) and s.key and s.marks.count("M") >= 3
    assert lay.series[0].colour != styles.assign(NAMES)["opt00"].colour  # not by position


@pytest.mark.parametrize("n", [1, 6, 7])
def test_a_short_legend_stays_inside_and_a_long_one_goes_beside(n):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    for name, st in styles.assign(NAMES[:n]).items():
        ax.plot([0, 1], [0, 1], **st.mpl(), label=name)
    legend = styles.legend(ax, n)
    fig.canvas.draw()
    outside = legend.get_window_extent().x0 >= ax.get_window_extent().x1
    assert outside == (n > 6)
    plt.close(fig)
