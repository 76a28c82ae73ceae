"""Issue 35, failure 9: names from records and archives reach the reader sanitised. A name
holding a terminal escape sequence (``ESC ] 0 ;`` sets the window title), a bell, a
bidirectional override or a newline that forges a table row is shown as visible escapes on
the terminal, in ``report.md`` and in HTML: it can neither act on a terminal nor start a line
of its own."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from hostile_helpers import TINY, run_cli

from vpid_bench.experiment import run_from_config
from vpid_bench.report.safe import clean, escape
from vpid_bench.report.site import environment
from vpid_bench.store import records as rec

#: A name that sets the window title, rings, colours, reverses the text and forges a row.
HOSTILE = "evil\x1b]0;pwned\x07\x1b[31m\u202e\r\n| forged | row |\x9b2J"
#: What must never reach a reader raw.
RAW = ("\x1b", "\x07", "\u202e", "\r", "\x9b")


def _html(text: str) -> str:
    """Record text as the HTML pages show it: cleaned, then auto-escaped by the templates."""
    return environment().from_string("{{ t }}").render(t=clean(text))


def _forged(text: str) -> list[str]:
    """Lines that the hostile name would have started (a forged table row: its pipes not
    escaped; a wrapped paragraph may start a line with the name's escaped ``forged \\|``)."""
    return [line for line in text.splitlines() if line.lstrip().startswith(("| forged",
                                                                           "forged |"))]


@pytest.mark.parametrize("text", [HOSTILE, "plain", "", "a\tb", "ü ∑ 日本", "\\x1b"])
def test_clean_leaves_one_printable_line_and_is_idempotent(text):
    out = clean(text)
    assert out.isprintable() and "\n" not in out
    assert clean(out) == out
    assert escape(text).isprintable() and _html(text).isprintable()
    if text.isprintable():
        assert out == text  # printable text is left exactly as it was


def test_each_renderer_keeps_its_own_rules():
    assert escape("a|b<i>&\nc") == "a\\|b&lt;i&gt;&amp; c"
    assert _html('<b title="x">\x1b') == "&lt;b title=&#34;x&#34;&gt;\\x1b"
    assert clean("a\nb\x1b", keep_newlines=True) == "a\nb\\x1b"


@pytest.fixture(scope="module")
def hostile_sweep(tmp_path_factory, compose_config, registry) -> Path:
    """A sweep of random and centre (on a problem whose instances have ids, so an archive of
    it can stand beside another sweep) whose centre records name their optimizer and a
    config value with the hostile text."""
    root = tmp_path_factory.mktemp("names") / "sweep"
    for opt in ("random", "centre"):
        run_from_config(compose_config([*TINY, "problem=smoke_quarter", f"optimizer={opt}",
                                        "runs=3"]), root / opt, registry)
    for path in rec.iter_record_files([root / "centre"]):
        data = json.loads(path.read_text())
        data["optimizer"]["name"] = HOSTILE
        data["problem"]["config"]["note"] = HOSTILE  # a config key: part of the context label
        path.write_text(json.dumps(data))
    return root


def _assert_sanitised(text: str, where: str) -> None:
    bad = [c for c in RAW if c in text]
    assert not bad, f"{where} holds raw {bad!r}"
    assert _forged(text) == [], f"{where} has a forged line"


def test_9_report_command_terminal_markdown_latex_html_are_sanitised(hostile_sweep, tmp_path):
    """The full report (tests, figures, LaTeX tables, HTML pages): the terminal, report.md,
    every .tex table and every page show the name visibly escaped (figure labels too:
    matplotlib once warned of the missing glyph of ESC on stderr, raw)."""
    out = tmp_path / "report"
    done = run_cli([str(hostile_sweep), "-o", str(out)], tmp_path, report=True)
    assert "Traceback" not in done.stderr, done.stderr[-2000:]
    assert done.returncode in (0, 1), done.stderr[-2000:]
    _assert_sanitised(done.stdout, "stdout")
    _assert_sanitised(done.stderr, "stderr")
    assert "evil\\x1b]0;pwned\\x07" in done.stdout  # shown, visibly, not dropped
    md = (out / "report.md").read_text(encoding="utf-8")
    _assert_sanitised(md, "report.md")
    assert "evil\\x1b\\]0;pwned\\x07" in md  # its ] escaped: no link can close on it
    tex, html = sorted(out.rglob("*.tex")), sorted(out.rglob("*.html"))
    assert tex and html
    for path in tex + html:  # LaTeX tables and the HTML pages (their labels are cleaned)
        _assert_sanitised(path.read_text(encoding="utf-8"), path.name)


def test_9_names_from_an_archive_are_sanitised(hostile_sweep, tmp_path):
    """The archive's notes (optimizer names of archived runs) are printed cleaned."""
    from vpid_bench.report.pack import pack

    base = tmp_path / "base"
    shutil.copytree(hostile_sweep, base)
    pack(base, "smoke", tmp_path / "archives" / "smoke", command="test", commit="abc",
              made_at="2026-01-01T00:00:00+00:00")
    mine = tmp_path / "mine"
    shutil.copytree(hostile_sweep / "random", mine / "random")
    for path in rec.iter_record_files([mine]):  # a third optimizer of mine, same problem
        data = json.loads(path.read_text())
        data["problem"]["config"]["note"] = HOSTILE
        path.write_text(json.dumps(data))
    out = tmp_path / "report"
    done = run_cli([str(mine), "-o", str(out), "--short", "--archive-dir",
                    str(tmp_path / "archives")], tmp_path, report=True)
    assert "Traceback" not in done.stderr, done.stderr[-2000:]
    assert "from the archive of suite smoke" in done.stderr, done.stderr  # it was merged
    _assert_sanitised(done.stdout + done.stderr, "the terminal")
    _assert_sanitised((out / "report.md").read_text(encoding="utf-8"), "report.md")
