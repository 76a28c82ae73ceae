"""The HTML site beside report.md, checked without a browser: every page type written, every
link resolving to a file, nothing from the network, record text escaped, the interactive
figures' data and geometry (the browser tests are in test_html_browser.py)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from report_synth import html_sweep

from vpid_bench.report import site, styles, svg
from vpid_bench.report.anytime import RunHits, ecdf
from vpid_bench.report.interactive import Figure, Series, ecdf_figure


@pytest.fixture(scope="module")
def report_dir(tmp_path_factory) -> Path:
    return html_sweep(tmp_path_factory.mktemp("html"))


def _pages(folder: Path) -> list[Path]:
    return sorted(folder.glob("*.html"))


def test_every_page_type_is_written_with_its_links_resolving(report_dir):
    names = {p.name for p in _pages(report_dir)}
    assert {"index.html", "protocol.html", "problem-vehicle.html",
            "problem-vehicle_b.html", "optimizer-de4.html", "optimizer-random.html"} <= names
    assert len([n for n in names if n.startswith("optimizer-")]) == 3
    assert site.check_links(report_dir, _pages(report_dir)) == []
    # an optimizer's page links each context to its section on the problem's page
    opt = (report_dir / "optimizer-de4.html").read_text(encoding="utf-8")
    assert 'href="problem-vehicle.html#c-vehicle_ps=20"' in opt
    assert 'id="c-vehicle_ps=20"' in (report_dir / "problem-vehicle.html").read_text()
    index = (report_dir / "index.html").read_text(encoding="utf-8")
    for target in ("problem-vehicle.html", "problem-vehicle_b.html", "optimizer-de4.html",
                   "optimizer-random.html", "protocol.html", "runs.csv", "report.md"):
        assert f'href="{target}"' in index


def test_a_broken_link_is_found(report_dir, tmp_path):
    """The control of the link check: a page naming a missing file, and ones on the web (a
    link to a paper too: the report's own links are the only links, issue 44 N5)."""
    page = tmp_path / "x.html"
    page.write_text('<a href="nope.html">a</a><img alt="x" src="https://example.org/a.png">'
                    '<link rel="stylesheet" href="//cdn.example.org/x.css">'
                    '<a class="x" href="https://doi.org/10.1/x">a paper</a>',
                    encoding="utf-8")
    assert site.check_links(tmp_path, [page]) == [
        "x.html: nope.html", "x.html: https://example.org/a.png (not a file of the report)",
        "x.html: //cdn.example.org/x.css (not a file of the report)",
        "x.html: https://doi.org/10.1/x (not a file of the report)"]


def test_nothing_is_loaded_from_the_network(report_dir):
    for page in _pages(report_dir):
        text = page.read_text(encoding="utf-8")
        assert not re.search(r'(?:src|href)="(?:https?:)?//', text), page.name
        assert re.findall(r"<script[^>]*>", text) == ['<script src="assets/report.js">'], page
        assert "@import" not in text and "url(" not in text


def test_record_names_are_escaped_on_every_page(report_dir):
    for page in _pages(report_dir):
        text = page.read_text(encoding="utf-8")
        assert "<script>alert" not in text and "<img src=x" not in text, page.name
    page = next(p for p in _pages(report_dir) if p.name.startswith("optimizer-de_img"))
    text = page.read_text(encoding="utf-8")
    assert "de&lt;img src=x onerror=&#34;alert(1)&#34;&gt;&amp;&lt;script&gt;" in text


def test_tables_sort_on_raw_values_and_units_are_shown(report_dir):
    text = (report_dir / "problem-vehicle.html").read_text(encoding="utf-8")
    assert "median NoRE (%)" in text  # the metric's unit in its header
    assert 'class="sortable"' in text
    # a numeric cell carries its full-precision value to sort by
    assert re.search(r'data-sort="\d+\.\d{6,}', text)


def test_every_figure_has_alt_text(report_dir):
    for page in _pages(report_dir):
        text = page.read_text(encoding="utf-8")
        for img in re.findall(r"<img [^>]*>", text):
            assert re.search(r'alt="[^"]{10,}"', img), (page.name, img)
        for fig in re.findall(r"<svg [^>]*>", text):
            if 'class="key"' in fig:  # a legend's key: decorative, its button names it
                assert 'aria-hidden="true"' in fig
                continue
            assert "role=\"img\"" in fig and "aria-labelledby" in fig


def test_a_convergence_figure_per_context_with_a_toggle_per_optimizer(report_dir):
    text = (report_dir / "problem-vehicle.html").read_text(encoding="utf-8")
    assert text.count('class="interactive"') == 1  # no optimum known: no ECDF
    assert text.count('class="toggle"') == 3 and text.count('class="series"') == 3


def test_a_single_jobs_report_has_its_site_too(tmp_path):
    out = html_sweep(tmp_path, short=True, evil="ga")
    assert site.check_links(out, _pages(out)) == []
    assert "single job" in (out / "index.html").read_text(encoding="utf-8")


def test_the_templates_are_strict():
    """An undefined value is an error, never an empty string; and values are escaped."""
    from jinja2 import UndefinedError

    env = site.environment()
    with pytest.raises(UndefinedError):
        env.from_string("{{ nothing.here }}").render()
    assert env.from_string("{{ x }}").render(x="<b>") == "&lt;b&gt;"


def test_markdown_from_a_section_cannot_insert_html():
    html = str(site.markdown_html("a <script>alert(1)</script> [x](javascript:alert(1))"))
    assert "<script>" not in html and 'href="javascript' not in html
    assert "&lt;script&gt;" in html


def test_the_ecdf_figure_holds_the_ecdf_it_shows():
    """Against :func:`.anytime.ecdf` at the figure's own points (an independent count)."""
    hits = [RunHits("c", "a", 100.0, 100.0, (5.0, 40.0) + (math.nan,) * 5),
            RunHits("c", "a", 100.0, 100.0, (2.0,) + (math.nan,) * 6),
            RunHits("c", "b", 100.0, 100.0, (math.nan,) * 7)]
    fig = ecdf_figure(hits, "c")
    a = next(s for s in fig.series if s.name == "a")
    assert a.y[-1] == pytest.approx(3 / 14)  # three of 2 x 7 (run, target) pairs
    for x, y in zip(a.x, a.y, strict=True):
        assert y == pytest.approx(float(ecdf([h for h in hits if h.algorithm == "a"], [x])[0]))
    assert next(s for s in fig.series if s.name == "b").y[-1] == 0.0
    assert ecdf_figure(hits, "other") is None


def test_svg_geometry_of_a_log_axis():
    """x = 1, 10, 100 on a log axis fall at the left edge, the middle and the right edge."""
    fig = Figure("k", "t", "alt", "x", "y", True, False,
                 (Series("a", (1.0, 10.0, 100.0), (0.0, 0.5, 1.0)),), y_range=(0.0, 1.0))
    lay = svg.layout(fig)
    mid = (svg.LEFT + svg.WIDTH - svg.RIGHT) / 2
    bottom, top = svg.HEIGHT - svg.BOTTOM, svg.TOP
    assert lay.series[0].path == (f"M{svg.LEFT:.1f} {bottom:.1f}H{mid:.1f}"
                                  f"V{(bottom + top) / 2:.1f}H{svg.WIDTH - svg.RIGHT:.1f}"
                                  f"V{top:.1f}H{svg.WIDTH - svg.RIGHT:.1f}")
    assert [t.label for t in lay.x_ticks] == ["1", "10", "100"]
    assert lay.series[0].colour == styles.PALETTE[0] and lay.series[0].dasharray == ""


def test_one_outline_orders_report_md_and_places_every_part_on_a_page(report_dir):
    """The registry of sections (report/outline.py): report.md is its parts in order, and
    each part the site shows from Markdown is on its page."""
    from vpid_bench.report import outline

    assert len({p.key for p in outline.PARTS}) == len(outline.PARTS)
    assert {p.page for p in outline.PARTS} <= set(outline.PAGES)
    assert {p.drawn for p in outline.PARTS} == {"page", "markdown"}
    md = (report_dir / "report.md").read_text(encoding="utf-8")
    heads = [md.index(h) for h in ("## Results", "## Rankings in detail",
                                   "## The mean identified vector", "## Per-run statistics",
                                   "## Statistical tests",
                                   "## How to read this report", "## Sources", "## Files")]
    assert heads == sorted(heads)
    protocol = (report_dir / "protocol.html").read_text(encoding="utf-8")
    for title in ("Statistical tests", "How to read this report", "Sources"):
        assert f"<h2>{title}</h2>" in protocol
    problem = (report_dir / "problem-vehicle.html").read_text(encoding="utf-8")
    assert "<h2>The mean identified vector" in problem  # the vehicle plugin's section
    assert "mean identified vector" not in protocol


def test_the_suite_ecdf_figure_weighs_each_problem_the_same():
    """Two problems of dimension 2 and 4; optimizer a hits its one target after 4 and 8
    evaluations (2 per parameter on both), so at 2 evaluations/D it has solved the same
    share on each: 1/7 each (one of 7 targets). b ran one problem only: left out."""
    from vpid_bench.report.interactive import suite_ecdf_figure

    nan = (math.nan,) * 6
    runs = [RunHits("p2", "a", 20.0, 20.0, (4.0, *nan)),
            RunHits("p4", "a", 40.0, 40.0, (8.0, *nan)),
            RunHits("p2", "b", 20.0, 20.0, (1.0, *nan))]
    fig = suite_ecdf_figure(runs, {"p2": ("f", 2), "p4": ("f", 4)})
    assert [s.name for s in fig.series] == ["a"]
    a = fig.series[0]
    for x, y in zip(a.x, a.y, strict=True):
        assert y == pytest.approx((1 / 7) if x >= 2.0 else 0.0)
    assert a.y[-1] == pytest.approx(1 / 7)
    assert suite_ecdf_figure(runs[:1], {"p2": ("f", 2)}) is None


@pytest.mark.parametrize("planted", ["index.html", "assets"])
def test_a_link_planted_in_the_report_folder_is_never_written_through(tmp_path, planted):
    """A symbolic link where the site writes a page or its assets, pointing outside the
    report folder: nothing is written outside; the report is written all the same (built
    beside the folder, it replaces it whole: the link goes with the old folder, issue 44 N6)
    and names the link in one line."""
    from vpid_bench.report.build import build_report

    outside = tmp_path / "outside"
    outside.mkdir()
    report = tmp_path / "s" / "report"
    report.mkdir(parents=True)
    (report / planted).symlink_to(outside / planted, target_is_directory=planted == "assets")
    if planted == "assets":
        (outside / planted).mkdir()
    html_sweep(tmp_path / "s", short=True, evil="ga")
    assert [p for p in outside.rglob("*") if p.is_file()] == []
    assert not (report / planted).is_symlink() and (report / "index.html").is_file()
    rep = build_report([tmp_path / "s"], report, short=True, archive=False)
    assert rep.folder_notes == []  # the folder it replaced held no link any more
    (report / "runs.csv").unlink()
    (report / "runs.csv").symlink_to(outside / "runs.csv")
    (note,) = build_report([tmp_path / "s"], report, short=True, archive=False).folder_notes
    assert note.startswith(f"warning: {report} held 1 symbolic link(s) ({report / 'runs.csv'})")
    assert not (outside / "runs.csv").exists()


def test_the_index_renders_the_verdict_objects(report_dir):
    """The verdict as data (report/verdicts.py) gives the index's one-line headline: the
    pick and those not separated from it, linked to their pages, and what limits it."""
    from vpid_bench.report.site_pages import decision
    from vpid_bench.report.verdicts import USE, Verdict

    pages = site.Pages(["p"], ["de1", "de4"])
    v = Verdict("p ps=20", "NoRE", "%", USE, pick="de4", tied=("de1",), limit="search")
    assert decision(v, pages) == {
        "kind": USE, "pick": ("de4", "optimizer-de4.html"),
        "tied": [("de1", "optimizer-de1.html")], "limit": "more search would still gain",
        "not_beaten": [], "over_bound": False}
    assert decision(Verdict("c", "m", "", "empty"), pages) is None
    index = (report_dir / "index.html").read_text(encoding="utf-8")
    assert index.count('<p class="pick">') == 2  # one per context, beside the verdict text
