"""Writing files safely: atomically, and never through a planted symbolic link.

Every file vpid-bench reads back from a results folder (records, job statuses, artifacts)
goes through :func:`read_text_limited`: a FIFO, a device or a folder planted under a record's
name is refused at once instead of blocking the reader, and so is a file over a size limit.

Every file vpid-bench writes (records, job statuses, reports, a problem's artifacts) goes
through :func:`write_text_atomic`: a crash leaves the old file or the new one, never a torn
one, and a link at the target path is replaced rather than followed (``os.replace`` renames
over the link itself). The folders it keeps inside an output folder (``optima``, ``report``)
are made by :func:`own_folder`, which never follows a link planted in their place.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import sys
import tempfile
from pathlib import Path
from typing import TextIO

#: The largest results file read back (a run record with a long trace is a few MB).
MAX_READ_BYTES = 64 * 1024 * 1024


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes, hex, read in 1 MB blocks: how a plugin checks a data file
    it ships or is pointed to against the checksum its docs state."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


#: The deepest nesting of JSON read from a results folder or an archive (arrays and objects
#: in one another). What vpid-bench writes nests 6 levels deep (a record's problem config
#: a few more); a value 900 deep parsed, then ran every recursive reader (the canonical form
#: of a record, a copy) past Python's recursion limit: a ``RecursionError`` traceback.
MAX_JSON_DEPTH = 64


def json_depth(value: object, limit: int = MAX_JSON_DEPTH) -> int:
    """How deep ``value`` (parsed JSON) nests lists and dicts (a scalar: 0), counted without
    recursion and only up to ``limit + 1`` (enough to know it is too deep)."""
    deepest = 0
    stack = [(value, 1)]
    while stack:
        node, depth = stack.pop()
        if type(node) is dict:
            children = node.values()
        elif type(node) is list:
            children = node
        else:
            continue
        deepest = max(deepest, depth)
        if depth > limit:
            break
        stack += [(c, depth + 1) for c in children if type(c) is dict or type(c) is list]
    return deepest


def loads_json(text: str) -> object:
    """``json.loads`` for untrusted text, the one way vpid-bench parses JSON it did not just
    make: JSON nested more than :data:`MAX_JSON_DEPTH` levels (a planted ``[[[[...]]]]``)
    is a ``json.JSONDecodeError`` like any other bad JSON (every reader catches
    ``ValueError``), never a ``RecursionError`` in the parser or in whatever reads it next."""
    try:
        value = json.loads(text)
    except RecursionError:
        value = None
    else:  # a text with fewer brackets than the limit cannot nest deeper (most files)
        if text.count("[") + text.count("{") <= MAX_JSON_DEPTH \
                or json_depth(value) <= MAX_JSON_DEPTH:
            return value
    raise json.JSONDecodeError(f"nested too deeply (more than {MAX_JSON_DEPTH} levels)",
                               text[:80], 0) from None


def json_fault(exc: Exception) -> str:
    """What is wrong with a text :func:`loads_json` refused, for a reader's one line: the
    parser's words (``nested too deeply (more than 64 levels)``), else the kind of fault."""
    return exc.msg if isinstance(exc, json.JSONDecodeError) else type(exc).__name__


def read_text_limited(path: Path, max_bytes: int = MAX_READ_BYTES) -> str:
    """The UTF-8 text of the regular file ``path`` (links followed). Raises ``OSError`` for
    anything else (a FIFO or device: opened without blocking, then refused) and for a file
    over ``max_bytes``; ``UnicodeDecodeError`` for bytes that are not UTF-8."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise OSError(f"{path}: not a regular file")
        if info.st_size > max_bytes:
            raise OSError(f"{path}: {info.st_size} bytes, more than {max_bytes}")
        with os.fdopen(os.dup(fd), "rb") as fh:
            data = fh.read(max_bytes + 1)
    finally:
        os.close(fd)
    if len(data) > max_bytes:
        raise OSError(f"{path}: more than {max_bytes} bytes")
    return data.decode("utf-8")


def _remove_planted_link(path: Path) -> None:
    """Remove the symbolic link at ``path`` (the link only, never what it points to) with one
    ``warning:`` line: a link planted where vpid-bench keeps a file or folder of its own."""
    path.unlink(missing_ok=True)  # another process may have removed it first
    print(f"warning: {path} was a symbolic link; removed (the link only) so that nothing "
          "is written outside the output folder", file=sys.stderr, flush=True)


def own_folder(path: Path) -> Path:
    """``path`` as a real folder of vpid-bench's own (created if needed): a symbolic link
    planted there (a sweep's ``optima`` or ``report`` pointing outside it: the files were
    once written wherever it pointed) is removed, the link only, with one ``warning:`` line,
    and a folder made in its place. Nothing is ever written through such a link."""
    path = Path(path)
    if path.is_symlink():
        _remove_planted_link(path)
    path.mkdir(parents=True, exist_ok=True)
    return path


#: How :func:`open_append` opens: never through a link at the last component, never
#: blocking on a FIFO, not inherited by a plugin's processes.
_APPEND_FLAGS = (os.O_WRONLY | os.O_APPEND | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0)
                 | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))


def open_append(path: Path) -> TextIO:
    """``path`` opened to append UTF-8 text (created if missing): a file vpid-bench keeps
    adding to (a job's log), which :func:`write_text_atomic` cannot write. A symbolic link
    planted there is removed (the link only) with one ``warning:`` line, as
    :func:`own_folder` does, and a file made in its place: a link to a file outside (a job
    folder's ``vpid_bench.log`` pointing elsewhere) was once appended to on every resume.
    Anything but a regular file (a FIFO, a device, a folder) is an ``OSError``, at once."""
    path = Path(path)
    try:
        fd = os.open(path, _APPEND_FLAGS, 0o666)
    except OSError:
        if not path.is_symlink():
            raise
        _remove_planted_link(path)
        fd = os.open(path, _APPEND_FLAGS, 0o666)  # a link planted again: OSError (ELOOP)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise OSError(f"{path}: not a regular file")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "a", encoding="utf-8")
    except BaseException:
        os.close(fd)
        raise


def write_text_atomic(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically: a temporary file in the same folder, fsync, then
    ``os.replace``. A crash at any moment leaves either no file or a complete one, and a
    symbolic link planted at ``path`` is replaced, never followed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; results are meant to be shared
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    """The process umask (read by setting and restoring it; there is no getter)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask
