"""File names made from untrusted text, and paths kept inside a folder: the rules every
writer of a file named from record content applies (report, IOHprofiler export)."""

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
    s = re.sub(r"_+", "_", re.sub(r"\.{2,}", "_", s)).strip("._-") or "x"
    if len(s) > max_len:
        digest = hashlib.sha256(str(text).encode()).hexdigest()[:10]
        s = s[: max_len - 11].rstrip("._-") + "-" + digest
    return s


class UnsafePathError(ValueError):
    """A path that would leave the folder it is written in."""


def inside(root: Path, path: Path) -> Path:
    """``path`` if it lies inside ``root`` (both resolved), else :class:`UnsafePathError`."""
    root_r = Path(root).resolve()
    path_r = Path(path).resolve()
    if path_r != root_r and root_r not in path_r.parents:
        raise UnsafePathError(f"{path} is outside the folder {root}")
    return path
