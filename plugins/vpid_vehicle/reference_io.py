"""Reading a measured record and writing the fitted reference, as CSV with a header row.

Written (``reference.csv``): ``t`` (s), ``z1dd_clean``, ``z2dd_clean``, ``z1dd_noisy``,
``z2dd_noisy`` (m/s^2): the front (z1'') and rear (z2'') body accelerations of Eq. (5)
without and with noise. For a measured record the clean columns are left empty.

Read (``problem.reference.file``): a header row naming ``t`` and either ``z1dd, z2dd`` or
``z1dd_noisy, z2dd_noisy`` (so a written reference.csv can be fitted again); other columns are
ignored. ``t`` must be the model's grid ``0, dt, 2 dt, ...`` with as many samples as the window.
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np

from vpid_bench import ConfigError, write_text_atomic

HEADER = ("t", "z1dd_clean", "z2dd_clean", "z1dd_noisy", "z2dd_noisy")
KEY = "problem.reference.file"


#: Largest reference file read (bytes): a measured record of MAX_SAMPLES rows is ~100 MB.
MAX_FILE_BYTES = 256 * 1024**2
_NAME = re.compile(r"[A-Za-z0-9_ .()/-]{1,40}")


def write_reference(
    path: Path, t: np.ndarray, noisy: np.ndarray, clean: np.ndarray | None
) -> Path:
    """Write ``reference.csv`` (see module docstring); ``noisy``/``clean`` are ``(2, N)``.
    Atomic, like every file vpid-bench writes: a crash or a full disk leaves the old file or
    the new one, never a torn one, and a link planted at ``path`` is replaced, not followed."""
    buffer = io.StringIO(newline="")
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(HEADER)
    for k in range(len(t)):
        c = ("", "") if clean is None else (repr(float(clean[0, k])), repr(float(clean[1, k])))
        writer.writerow(
            (repr(float(t[k])), *c, repr(float(noisy[0, k])), repr(float(noisy[1, k])))
        )
    return write_text_atomic(Path(path), buffer.getvalue())


def _header_text(header: list[str]) -> str:
    """The header as read, when it looks like column names (never other file content)."""
    if header and all(_NAME.fullmatch(h) for h in header) and len(header) <= 20:
        return "found columns " + ", ".join(header)
    return "found no such header row"


def _rows(path: Path, limit: int) -> list[list[str]]:
    """The CSV rows of ``path`` (a UTF-8 byte-order mark is accepted), at most ``limit``;
    ConfigError for a file that is not UTF-8 text or not CSV (no content is quoted)."""
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ConfigError(KEY, str(path), f"a CSV file of at most {MAX_FILE_BYTES // 1024**2}"
                              f" MiB (this one: {size / 1024**2:.0f} MiB)")
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = []
            for row in csv.reader(fh):
                rows.append(row)
                if len(rows) > limit:
                    break
            return rows
    except UnicodeDecodeError as exc:
        raise ConfigError(KEY, str(path), f"a text CSV file in UTF-8 (byte {exc.start} is not "
                          "UTF-8: a binary file?)") from None
    except csv.Error as exc:
        raise ConfigError(KEY, str(path), f"a text CSV file ({exc})") from None
    except OSError as exc:
        raise ConfigError(KEY, str(path), f"a readable CSV file ({exc.strerror})") from None


def read_measured(path: str | Path, t_model: np.ndarray, dt: float) -> np.ndarray:
    """The measured z1'', z2'' as ``(2, N)``; ConfigError if the file, its columns or its time
    grid do not fit the model's grid ``t_model`` (step ``dt`` in s), if a value is not a
    finite number, or if every acceleration is zero (nothing to fit)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(KEY, str(path), "an existing CSV file (columns t, z1dd, z2dd)")
    N = len(t_model)
    rows = _rows(path, N + 1)
    if not rows:
        raise ConfigError(KEY, str(path), "a CSV with a header row t, z1dd, z2dd (file is empty)")
    header = [h.strip() for h in rows[0]]
    names = None
    for pair in (("z1dd", "z2dd"), ("z1dd_noisy", "z2dd_noisy")):
        if "t" in header and all(p in header for p in pair):
            names = ("t", *pair)
            break
    if names is None:
        raise ConfigError(
            KEY, str(path),
            "a header with columns t, z1dd, z2dd (or t, z1dd_noisy, z2dd_noisy); "
            + _header_text(header),
        )
    idx = [header.index(n) for n in names]
    body = [r for r in rows[1:] if r]
    grid = (f"t = 0 ... {t_model[-1]:g} s at problem.dt = {dt:g} s; change problem.dt or "
            "problem.record.extra to match the file")
    if len(body) != N:
        found = f"more than {N}" if len(rows) > N + 1 else str(len(body))
        raise ConfigError(KEY, str(path), f"{N} rows of samples ({grid}); found {found}")
    data = np.empty((N, 3))
    for k, row in enumerate(body):
        for j, i in enumerate(idx):
            try:
                value = float(row[i])
            except (ValueError, IndexError):
                raise ConfigError(KEY, str(path), f"a number in column {names[j]} of every row; "
                                  f"row {k + 2} has none") from None
            if not np.isfinite(value):
                raise ConfigError(KEY, str(path), f"finite numbers; row {k + 2} column "
                                  f"{names[j]} is {value}")
            data[k, j] = value
    bad = np.abs(data[:, 0] - t_model) > max(1e-9, 1e-6 * dt)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise ConfigError(
            KEY, str(path),
            f"a t column equal to k * problem.dt = k * {dt:g} s; row {k + 2} has t = "
            f"{data[k, 0]:g} s, expected {t_model[k]:g} s",
        )
    if not np.any(data[:, 1:]):
        raise ConfigError(KEY, str(path), f"a record with some nonzero acceleration (every "
                          f"{names[1]}, {names[2]} value is 0: nothing to fit)")
    return np.ascontiguousarray(data[:, 1:].T)
