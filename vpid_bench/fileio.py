"""Reading and writing files safely: atomically, and never through a planted symbolic link
(docs/sweeps.md, files: atomic, no links followed, non-finite numbers kept).

Results files are read back through :func:`read_text_limited` (a FIFO, device or folder
refused, a size limit) and :func:`loads_json`; written through :func:`write_text_atomic`, the
folders kept through :func:`own_folder`, a folder that must be one thing whole (a report)
through :class:`WholeFolder` (issue 44, N8: two reports at once once mixed their pages; N6).
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import hashlib
import json
import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import TextIO

from .interrupts import held

#: The largest results file read back (a run record with a long trace is a few MB).
MAX_READ_BYTES = 64 * 1024 * 1024


def file_sha256(path: Path) -> str:
    """A file's SHA-256, hex: how a plugin checks a data file it ships or is pointed to."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


#: The deepest nesting of JSON read from a results folder or an archive. What vpid-bench
#: writes nests about 6 levels; a value 900 deep once ran every recursive reader past
#: Python's recursion limit: a ``RecursionError`` traceback.
MAX_JSON_DEPTH = 64


def json_depth(value: object, limit: int = MAX_JSON_DEPTH) -> int:
    """How deep ``value`` (parsed JSON) nests lists and dicts (a scalar: 0), without
    recursion and only up to ``limit + 1``."""
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
    """``json.loads`` for untrusted text: JSON nested past :data:`MAX_JSON_DEPTH` is a
    ``json.JSONDecodeError`` like any other bad JSON, never a ``RecursionError``."""
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
    """What is wrong with a text :func:`loads_json` refused, for a reader's one line."""
    return exc.msg if isinstance(exc, json.JSONDecodeError) else type(exc).__name__


def read_text_limited(path: Path, max_bytes: int = MAX_READ_BYTES) -> str:
    """The UTF-8 text of the regular file ``path`` (links followed); ``OSError`` for anything
    else (opened without blocking) or a file over ``max_bytes``."""
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
    """Remove a link planted where vpid-bench keeps a file or folder, with one ``warning:`` line."""
    path.unlink(missing_ok=True)  # another process may have removed it first
    print(f"warning: {path} was a symbolic link; removed (the link only) so that nothing "
          "is written outside the output folder", file=sys.stderr, flush=True)


#: The errors of a write the system refused: a file-size limit (``EFBIG``, RLIMIT_FSIZE with
#: SIGXFSZ ignored), a full disk or quota, a read-only or failing disk.
WRITE_REFUSED = frozenset(getattr(errno, n) for n in (
    "EFBIG", "ENOSPC", "EDQUOT", "EROFS", "EIO") if hasattr(errno, n))


def write_refused(exc: BaseException) -> bool:
    """Whether ``exc`` (or its cause) is a write the system refused: never swallowed as a
    figure's or plugin's fault (issue 44, N9: a report once left out every figure, torn)."""
    while exc is not None:
        if isinstance(exc, OSError) and exc.errno in WRITE_REFUSED:
            return True
        exc = exc.__cause__ or exc.__context__  # type: ignore[assignment]
    return False


def own_folder(path: Path) -> Path:
    """``path`` as a real folder of vpid-bench's own (created if needed): a link planted
    there (files were once written wherever it pointed) is removed with one line."""
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
    """``path`` opened to append UTF-8 text (a job's log): a link planted there is removed
    with one line (one was once appended to on every resume); ``OSError`` if not a file."""
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
    """Write ``text`` to ``path`` atomically (a temporary file, fsync, ``os.replace``): a
    crash leaves no file or a complete one; a link at ``path`` is replaced, never followed."""
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


class WholeFolder:
    """A folder written whole or not at all: ``with WholeFolder(out) as new:`` write into
    ``new`` (hidden, beside ``out``); when the block ends without an exception, ``new``
    takes ``out``'s place in one step (``renameat2(RENAME_EXCHANGE)``; elsewhere two renames)
    with the interrupting signals held and the parent locked (two writers swap in turn), and
    the old folder is removed, never followed through a link (:attr:`links` names them). When
    the block raises, ``new`` is removed. A mount point's entries are swapped instead (not
    atomic). Only SIGKILL or a crash can leave ``.<name>.new-*`` behind.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(os.path.abspath(path))  # "." and "x/.." have a name and a parent
        self.links: list[Path] = []  # links the replaced folder held, as paths under it
        self._new: Path | None = None
        self._old: Path | None = None

    def __enter__(self) -> Path:
        path = self.path
        mounted = path.is_dir() and not path.is_symlink() and os.path.ismount(path)
        base = path if mounted else path.parent
        base.mkdir(parents=True, exist_ok=True)
        self._new = Path(tempfile.mkdtemp(prefix=f".{path.name}.new-", dir=base))
        os.chmod(self._new, 0o777 & ~_umask())  # mkdtemp makes 0700; a report is shared
        return self._new

    def __exit__(self, exc_type: type[BaseException] | None, *_: object) -> None:
        assert self._new is not None, "WholeFolder used without entering it"
        if exc_type is not None:
            shutil.rmtree(self._new, ignore_errors=True)
            return
        try:
            self._swap(self._new)
        except BaseException:  # the swap failed (the old folder is in place), or a signal
            shutil.rmtree(self._old or self._new, ignore_errors=True)  # held back came now
            raise
        if self._old is not None:
            self.links += _links_below(self._old, self.path)
            shutil.rmtree(self._old, ignore_errors=True)

    def _swap(self, new: Path) -> None:
        """``new`` into :attr:`path`'s place; :attr:`_old` names the replaced folder."""
        path = self.path
        with held(), _locked(path.parent):
            if path.is_symlink():  # planted in the folder's place: the link only goes
                path.unlink()
                self.links.append(path)
            if not os.path.lexists(path):
                os.rename(new, path)
                return
            if not path.is_dir():
                raise NotADirectoryError(errno.ENOTDIR, "not a folder", str(path))
            if new.parent == path:  # a mount point
                self._old = _swap_entries(new, path)
            elif _exchange(new, path):
                self._old = new
            else:
                old = new.with_name(new.name.replace(".new-", ".old-", 1))
                os.rename(path, old)
                try:
                    os.rename(new, path)
                except OSError:
                    os.rename(old, path)
                    raise
                self._old = old


def _exchange(a: Path, b: Path) -> bool:
    """Swap ``a`` and ``b`` in one step (Linux ``renameat2``); False where the system or
    file system cannot (nothing happened)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):  # a C library without it (glibc < 2.28, musl)
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                          ctypes.c_uint]
    at_fdcwd, rename_exchange = -100, 2
    return renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0


def _swap_entries(new: Path, path: Path) -> Path:
    """The entries of the mount point ``path`` moved into a hidden folder in it (returned),
    those of ``new`` moved in."""
    old = Path(tempfile.mkdtemp(prefix=f".{path.name}.old-", dir=path))
    for entry in os.listdir(path):
        if entry not in (new.name, old.name):
            os.rename(path / entry, old / entry)
    for entry in os.listdir(new):
        os.rename(new / entry, path / entry)
    new.rmdir()
    return old


@contextlib.contextmanager
def _locked(folder: Path) -> Iterator[None]:
    """An exclusive ``flock`` on ``folder`` itself, where the system has one."""
    try:
        import fcntl

        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except (ImportError, OSError):
        yield
        return
    try:
        with contextlib.suppress(OSError):
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def _links_below(folder: Path, shown_as: Path, limit: int = 20) -> list[Path]:
    """At most ``limit`` links in ``folder`` (not followed), as paths under ``shown_as``."""
    found: list[Path] = []
    for root, dirs, files in os.walk(folder):
        for name in [*dirs, *files]:
            if os.path.islink(os.path.join(root, name)) and len(found) < limit:
                found.append(shown_as / Path(root, name).relative_to(folder))
    return found


def _umask() -> int:
    """The process umask (read by setting and restoring it; there is no getter)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask
