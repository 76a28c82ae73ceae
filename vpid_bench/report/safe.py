"""Untrusted text made safe for a reader: the terminal (:func:`clean`), Markdown
(:func:`escape`) and HTML (the site's templates auto-escape text that :func:`clean` made one
printable line). File names and paths made from record content follow
:mod:`vpid_bench.store.paths` (``slug``, ``inside``).

Records, archives and result folders may come from anyone: a problem name, an optimizer
parameter or a context label can hold ``../``, ``/``, ``|``, HTML, a thousand characters, a
terminal escape sequence (``ESC ] 0 ;`` sets the window title) or a newline that forges a
table row. Every piece of record text shown to a person is first made one line of printable
characters (:func:`clean`), then escaped for its renderer. This module is the one home of
those rules: every renderer (terminal, Markdown, HTML) uses it.

Text is text (issue 44, N5): a run's error message or a plugin section holding
``![x](http://...)``, ``[x](https://...)``, ``<http://...>``, ``<img src=...>``, a reference
link or a bare URL once became a real image or link in report.md and on the HTML pages, and
opening the site fetched from the network. :func:`escape` (record text) and
:func:`inert_markdown` (a plugin section's Markdown: its tables and emphasis kept) make all of
them inert text for any CommonMark or GitHub renderer: ``[`` and ``]`` escaped (no link, image
or reference), ``<`` escaped (no HTML, no autolink), and the ``:`` of ``scheme://``, the ``.``
of ``www.`` and the ``@`` of an e-mail address escaped (no bare-URL autolink). The report's
own links (to its files and pages) are made by its renderers, never from such text, and are
the only ones: :func:`local_link` is the rule the HTML renderer and the link check apply.
"""

from __future__ import annotations

import re


def _visible(char: str) -> str:
    """A character that is not printable as its Python escape (``\\x1b``, ``\\n``,
    ``\\u202e``): visible, and inert on any terminal."""
    return repr(char)[1:-1]


def clean(text: object, keep_newlines: bool = False) -> str:
    """``text`` as printable characters only: every control character (C0 and C1, so every
    terminal escape sequence, and line breaks), every format character (bidirectional
    overrides) and every separator other than the space is written as its escape (ESC as
    ``\\x1b``), so it cannot act on a terminal nor start a line of its own.
    ``keep_newlines``: a block of several lines (a terminal table) keeps its ``\\n``, each
    line cleaned. Idempotent: cleaning clean text changes nothing."""
    s = str(text)
    if keep_newlines:
        return "\n".join(clean(line) for line in s.split("\n"))
    if s.isprintable():  # the usual case, in one pass
        return s
    return "".join(c if c.isprintable() else _visible(c) for c in s)


_MD_ESCAPES = {"|": "\\|", "&": "&amp;", "<": "&lt;", ">": "&gt;", "`": "'",
               "\n": " ", "\r": " ", "\t": " ", "[": "\\[", "]": "\\]"}
#: A backslash that would escape what follows it (ASCII punctuation, or whatever the report
#: writes after the text): doubled, so it is shown. Before a letter it is shown as it is.
_MD_BACKSLASH = re.compile(r"\\(?=[!-/:-@\[-`{-~]|$)")

#: What a Markdown renderer turns into a link or an image on its own (GitHub's autolinks):
#: the ``:`` of ``scheme://`` (and of ``mailto:``/``xmpp:``), the ``.`` of ``www.`` and the
#: ``@`` of an e-mail address. Each is backslash-escaped: shown as is, linked by no renderer.
_AUTOLINK = re.compile(
    r"(?<![a-z0-9+.-])[a-z][a-z0-9+.-]{0,31}:(?=//)"  # scheme://
    r"|(?<![a-z0-9+.-])(?:mailto|xmpp):"
    r"|(?<![a-z0-9_-])www\."
    r"|(?<=[a-z0-9._+-])@(?=[a-z0-9_-]+\.)", re.IGNORECASE)


def _inert_autolinks(text: str) -> str:
    """``text`` with each autolink trigger (:data:`_AUTOLINK`) backslash-escaped."""
    return _AUTOLINK.sub(lambda m: m.group(0)[:-1] + "\\" + m.group(0)[-1], text)


def escape(text: object) -> str:
    """Record text for a Markdown line or table cell, shown as it is and nothing else: ``|``,
    ``[``, ``]`` and a ``\\`` that would escape the next character backslash-escaped (no
    table cell, link, image or reference), HTML (``& < >``) as entities (no tag, no
    autolink), backticks as quotes, the triggers of bare-URL autolinks escaped, line breaks
    as spaces, any other control or format character made visible (:func:`clean`)."""
    s = _MD_BACKSLASH.sub(r"\\\\", str(text))
    return clean(_inert_autolinks("".join(_MD_ESCAPES.get(c, c) for c in s)))


#: A backslash escape already in Markdown (kept as it is), or a character that starts a
#: link, an image, a reference, HTML or an autolink (escaped).
_MD_ACTIVE = re.compile(r"\\[!-/:-@\[-`{-~]|[\[\]<]")


def inert_markdown(text: object) -> str:
    """A plugin section's Markdown with every link, image, reference, raw HTML and autolink
    made text, the rest (tables, emphasis, headings, lists, code) kept: each ``[``, ``]`` and
    ``<`` not already escaped is backslash-escaped, and so are the triggers of bare-URL
    autolinks. Inside a code span these escapes show as typed (a small price: telling code
    from text is the renderer's parse, which a hostile text can steer)."""
    s = _MD_ACTIVE.sub(lambda m: m.group(0) if len(m.group(0)) == 2 else "\\" + m.group(0),
                       str(text))
    return _inert_autolinks(s)


def local_link(url: str) -> bool:
    """Whether ``url`` names a file of the report itself: a relative path with no scheme,
    host, absolute path, ``..`` or backslash (``figures/x.png``, ``problem-x.html#ctx``). Any other
    (``https://``, ``//host``, ``data:``, ``file:``, ``/etc``) is never a link of the report."""
    u = str(url).strip()
    return bool(u) and not (re.match(r"[A-Za-z][A-Za-z0-9+.-]*:", u) or u.startswith("/")
                            or "\\" in u or ".." in u.split("#")[0].split("/")
                            or any(not c.isprintable() for c in u))
