"""The terminal shows Markdown text as a reader sees it: the escapes that keep record text
inert in report.md and the HTML pages (``\\[``, ``\\|``, ``&lt;``, ``http\\://``) are undone on
the terminal, where they once showed as typed ("Searched within the boxes: \\[0.5, 1.5\\]")."""

from __future__ import annotations

import string

from hypothesis import given
from hypothesis import strategies as st

from vpid_bench.report import first_screen
from vpid_bench.report.render import terminal
from vpid_bench.report.safe import escape, shown

#: Printable ASCII but the backtick (escape() shows it as a quote) and whitespace runs.
TEXT = st.text(alphabet=sorted(set(string.printable) - set("`\t\n\r\x0b\x0c")), max_size=60)


@given(TEXT)
def test_what_escape_writes_is_shown_as_it_was(text):
    assert shown(escape(text)) == text


def test_a_terminal_table_and_prose_show_no_markdown_escapes():
    table = terminal(["name", "box"], [[escape("x|[y] <z>"), escape("[0.5, 1.5]")]])
    assert "x|[y] <z>" in table and "[0.5, 1.5]" in table and "\\" not in table
    prose = first_screen._wrap("Searched within the boxes: " + escape("[0.5, 1.5] x set"), 80)
    assert prose == "Searched within the boxes: [0.5, 1.5] x set"
