"""Untrusted text made safe: file names (:func:`slug`), paths kept inside the report folder
(:func:`inside`), and record text going into Markdown (:func:`escape`).

Records and result folders may come from anyone: a problem name, an optimizer parameter or a
context label can hold ``../``, ``/``, ``|``, HTML or a thousand characters. Every file name
the report builds from record content goes through :func:`slug`, every path it writes is
checked by :func:`inside`, and every piece of record text placed in ``report.md`` goes
through :func:`escape`.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

#: Longest file-name stem :func:`slug` returns (characters).
MAX_SLUG = 80


def slug(text: str, max_len: int = MAX_SLUG) -> str:
    """A file-name-safe form of ``text``: only ``[A-Za-z0-9._=-]``, no ``..``, no leading dot
    or dash, at most ``max_len`` characters (a long text keeps its start and gets a short
    hash of the whole, so distinct long texts stay distinct). Never empty."""
    s = re.sub(r"[^A-Za-z0-9._=-]+", "_", str(text))
    s = re.sub(r"_+", "_", re.sub(r"\.{2,}", "_", s)).strip("._-")
    if not s:
        s = "x"
    if len(s) > max_len:
        digest = hashlib.sha256(str(text).encode()).hexdigest()[:10]
        s = s[: max_len - 11].rstrip("._-") + "-" + digest
    return s


class UnsafePathError(ValueError):
    """A path that would leave the report folder."""


def inside(root: Path, path: Path) -> Path:
    """``path`` if it lies inside ``root`` once both are resolved; else
    :class:`UnsafePathError`."""
    root_r = Path(root).resolve()
    path_r = Path(path).resolve()
    if path_r != root_r and root_r not in path_r.parents:
        raise UnsafePathError(f"{path} is outside the report folder {root}")
    return path


_MD_ESCAPES = {"|": "\\|", "&": "&amp;", "<": "&lt;", ">": "&gt;", "`": "'",
               "\n": " ", "\r": " ", "\t": " "}


def escape(text: object) -> str:
    """Record text for a Markdown line or table cell: ``|`` escaped, HTML (``& < >``) as
    entities, backticks as quotes, line breaks as spaces."""
    return "".join(_MD_ESCAPES.get(c, c) for c in str(text))
