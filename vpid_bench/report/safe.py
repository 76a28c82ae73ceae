"""Untrusted text made safe for a reader, the one home of those rules: records, archives and
result folders may come from anyone, and a name or label can hold ``../``, ``|``, HTML, a
terminal escape sequence (``ESC ] 0 ;`` sets the window title) or a newline that forges a
table row. Record text shown to a person is first made one line of printable characters
(:func:`clean`, the terminal), then escaped for its renderer (:func:`escape`, Markdown; the
site's templates auto-escape HTML). File names made from record content follow
:mod:`vpid_bench.store.paths`.

Text is text (issue 44, N5): :func:`escape` (record text) and :func:`inert_markdown` (a
plugin section's Markdown, tables and emphasis kept) make links, images, HTML and autolinks
(``scheme://``, ``www.``, e-mail addresses) inert for any CommonMark or GitHub renderer. The
report's own links are the only ones: :func:`local_link` is the rule the HTML renderer and
the link check apply."""

from __future__ import annotations

import re


def clean(text: object, keep_newlines: bool = False) -> str:
    """``text`` as printable characters only: every control, format or separator character
    but the space written as its escape (ESC as ``\\x1b``), so it cannot act on a terminal
    nor start a line; ``keep_newlines`` keeps a block's ``\\n``. Idempotent."""
    s = str(text)
    if keep_newlines:
        return "\n".join(clean(line) for line in s.split("\n"))
    if s.isprintable():  # the usual case, in one pass
        return s
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in s)  # its Python escape


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
    """Record text for a Markdown line or cell, shown as it is: ``|``, ``[``, ``]``, a
    trailing-escape ``\\`` and autolink triggers backslash-escaped, ``& < >`` as entities,
    backticks as quotes, line breaks as spaces, the rest :func:`clean`."""
    s = _MD_BACKSLASH.sub(r"\\\\", str(text))
    return clean(_inert_autolinks("".join(_MD_ESCAPES.get(c, c) for c in s)))


#: A Markdown backslash escape (of ASCII punctuation) or one of the entities :func:`escape` writes.
_MD_SHOWN = re.compile(r"\\([!-/:-@\[-`{-~])|&(amp|lt|gt);")


def shown(markdown: str) -> str:
    """Markdown text as a reader sees it, for the terminal: the backslash escapes and the
    entities :func:`escape` writes undone (``\\[0.5, 1.5\\]`` shows as ``[0.5, 1.5]``)."""
    return _MD_SHOWN.sub(lambda m: m.group(1) or {"amp": "&", "lt": "<", "gt": ">"}[m.group(2)],
                         markdown)


#: A backslash escape already in Markdown (kept as it is), or a character that starts a
#: link, an image, a reference, HTML or an autolink (escaped).
_MD_ACTIVE = re.compile(r"\\[!-/:-@\[-`{-~]|[\[\]<]")


def inert_markdown(text: object) -> str:
    """A plugin section's Markdown with every link, image, reference, raw HTML and autolink
    made text (each unescaped ``[``, ``]``, ``<`` and autolink trigger escaped), the rest
    kept; inside a code span the escapes show as typed."""
    s = _MD_ACTIVE.sub(lambda m: m.group(0) if len(m.group(0)) == 2 else "\\" + m.group(0),
                       str(text))
    return _inert_autolinks(s)


def local_link(url: str) -> bool:
    """Whether ``url`` names a file of the report: a relative path with no scheme, host,
    absolute path, ``..`` or backslash (``figures/x.png``, ``problem-x.html#ctx``)."""
    u = str(url).strip()
    return bool(u) and not (re.match(r"[A-Za-z][A-Za-z0-9+.-]*:", u) or u.startswith("/")
                            or "\\" in u or ".." in u.split("#")[0].split("/")
                            or any(not c.isprintable() for c in u))
