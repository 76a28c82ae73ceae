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
from pathlib import Path

import numpy as np

from vpid_bench.api import ConfigError

HEADER = ("t", "z1dd_clean", "z2dd_clean", "z1dd_noisy", "z2dd_noisy")
KEY = "problem.reference.file"


def write_reference(
    path: Path, t: np.ndarray, noisy: np.ndarray, clean: np.ndarray | None
) -> Path:
    """Write ``reference.csv`` (see module docstring); ``noisy``/``clean`` are ``(2, N)``."""
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(HEADER)
        for k in range(len(t)):
            c = ("", "") if clean is None else (repr(float(clean[0, k])), repr(float(clean[1, k])))
            writer.writerow(
                (repr(float(t[k])), *c, repr(float(noisy[0, k])), repr(float(noisy[1, k])))
            )
    return path


def read_measured(path: str | Path, t_model: np.ndarray, dt: float) -> np.ndarray:
    """The measured z1'', z2'' as ``(2, N)``; ConfigError if the file, its columns or its time
    grid do not fit the model's grid ``t_model`` (step ``dt`` in s)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(KEY, str(path), "an existing CSV file (columns t, z1dd, z2dd)")
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
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
            f"a header with columns t, z1dd, z2dd (or t, z1dd_noisy, z2dd_noisy); found {header}",
        )
    idx = [header.index(n) for n in names]
    try:
        data = np.array([[float(r[i]) for i in idx] for r in rows[1:] if r], dtype=float)
    except (ValueError, IndexError) as exc:
        allowed = f"numbers in columns {', '.join(names)} ({exc})"
        raise ConfigError(KEY, str(path), allowed) from None
    N = len(t_model)
    if data.shape[0] != N or not np.all(np.isfinite(data)):
        raise ConfigError(
            KEY, str(path),
            f"{N} finite samples (t = 0 ... {t_model[-1]:g} s at problem.dt = {dt:g} s; change "
            f"problem.dt or problem.record.extra to match the file); found {data.shape[0]}",
        )
    bad = np.abs(data[:, 0] - t_model) > max(1e-9, 1e-6 * dt)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise ConfigError(
            KEY, str(path),
            f"a t column equal to k * problem.dt = k * {dt:g} s; row {k + 1} has t = "
            f"{data[k, 0]:g} s, expected {t_model[k]:g} s",
        )
    return np.ascontiguousarray(data[:, 1:].T)
