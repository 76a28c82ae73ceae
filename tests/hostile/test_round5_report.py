"""Round five's report failures (issue 44), each named by its id: N16 (the built-in test
functions' first screen called them "a measured record" and reported profile-likelihood
failures on a clean run), N5 (links and images in records and plugin sections were real
ones)."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest


@pytest.mark.parametrize("function", ["sphere", "rastrigin"])
def test_n16_test_functions_are_no_measured_record(function, tmp_path, registry):
    """A clean run of a test function whose minimiser has a zero coordinate (no truth is
    offered): no "measured record", no profile likelihood, no intervals and no fit diagnostics
    (there is no record to identify), and the first screen says why there is no truth."""
    from vpid_functions.plugin import FunctionsConfig

    from vpid_bench.experiment import run_from_config
    from vpid_bench.params import hydra_node
    from vpid_bench.report.build import build_report

    cfg = {"problem": hydra_node(FunctionsConfig, "functions") | {
               "function": function, "dim": 3, "iterations": 5, "ps": 8},
           "optimizer": {"name": "de1"}, "seed": 0, "runs": 3, "progress": False,
           "report": False}
    summary = run_from_config(cfg, tmp_path, registry=registry)
    recs = [json.loads(p.read_text()) for p in summary.record_paths]
    assert all(r["status"] == "ok" for r in recs)
    assert all(r["problem"]["info"]["fits_a_record"] is False for r in recs)
    assert all("intervals" not in r["result"] for r in recs)
    assert not (tmp_path / "profile.json").exists()
    assert not (tmp_path / "diagnostics.json").exists()
    build_report([tmp_path], tmp_path / "report", short=True)
    text = " ".join((tmp_path / "report" / "report.md").read_text().split())
    assert "measured record" not in text and "profile likelihood failed" not in text
    assert "No truth is offered by this problem (it fits no record)" in text
    assert "Fit diagnostics" not in text


def test_n16_a_record_fitting_problem_without_truth_keeps_its_wording():
    """The other side: a problem that fits a record (the default) keeps "a measured record"."""
    from vpid_bench.problem import Problem
    from vpid_bench.report.estimates import NO_TRUTH

    assert Problem.fits_a_record is True and "a measured record" in NO_TRUTH


def _report_synth():
    """tests/report/report_synth.py (synthetic records, the N5 sweep)."""
    sys.path.insert(0, str(Path(__file__).parents[1] / "report"))
    import report_synth

    return report_synth


#: An attribute that would make a browser load something from another host.
REMOTE = re.compile(r"""(?:href|src)\s*=\s*["']?\s*(?:[a-z][a-z0-9+.-]*:)?//""", re.IGNORECASE)


@pytest.mark.parametrize("short", [True, False])
def test_n5_links_and_images_in_records_and_plugin_sections_are_text(tmp_path, short):
    """A failed run's error message, an optimizer's name and a plugin's section (title, text,
    table, headline column) holding an image, a link, an autolink, a bare URL, a ``www.``
    address, a reference-style link and raw HTML: report.md, rendered as GitHub would (raw
    HTML allowed), and every HTML page hold no link or image to anything but the report's own
    files; the text is shown, as text; the section's emphasis and the report's own figures
    and links stay."""
    from markdown_it import MarkdownIt

    out = _report_synth().links_sweep(tmp_path / "s", short=short)
    md = (out / "report.md").read_text(encoding="utf-8")
    rendered = MarkdownIt("commonmark", {"html": True}).enable("table").render(md)
    assert not REMOTE.search(rendered), REMOTE.search(rendered)
    # no bare URL or www. address a renderer would make a link of (their ':' and '.' escaped)
    assert not re.search(r"(?i)(?:https?|ftp)://|www\.n5|mailto:", md)
    text_md = " ".join(rendered.split())
    for shown in ("n5-image.png", "n5-link", "n5-autolink", "n5-bare", "www.n5.invalid",
                  "n5-html.png", "[n5 ref][r]", "n5-title", "n5-name.png"):
        assert shown in text_md, shown  # shown, as text
    pages = sorted(out.glob("*.html"))
    assert len(pages) >= 4
    for page in pages:
        html = page.read_text(encoding="utf-8")
        assert not REMOTE.search(html), (page.name, REMOTE.search(html))
    problem = (out / "problem-vehicle.html").read_text(encoding="utf-8")
    assert "http://127.0.0.1:9/n5-image.png" in problem and "<em>kept</em>" in problem
    assert "http://127.0.0.1:9/n5-ref" in (out / "protocol.html").read_text(encoding="utf-8")
    if not short:  # the report's own images are still images
        assert re.search(r'<img[^>]+src="figures/[^"]+\.png"', problem)
        assert re.search(r"!\[[^\]]*\]\(figures/\S+\.png\)", md)


def test_n5_only_the_reports_own_files_are_links():
    """The rule the HTML renderer and the link check apply (:func:`.safe.local_link`), and
    the Markdown parser of the pages refusing anything else even when given a real link."""
    from vpid_bench.report.safe import local_link
    from vpid_bench.report.site import markdown_html

    for url in ("figures/a.png", "tables/t.csv", "problem-x.html#c-1", "report.md"):
        assert local_link(url), url
    for url in ("https://x", "http://x", "//x/y.png", "data:image/png;base64,AA", "file:///e",
                "/etc/passwd", "javascript:alert(1)", "../x.png", "a\\b", " HTTPS://x", ""):
        assert not local_link(url), url
    html = str(markdown_html("[a](https://x/a) ![b](http://x/b.png) ![c](figures/c.png) "
                             "[d](tables/d.csv)"))
    assert 'src="figures/c.png"' in html and 'href="tables/d.csv"' in html
    assert not REMOTE.search(html) and "https://x/a" in html
