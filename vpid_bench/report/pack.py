"""Making an archive from a finished sweep: its records, optima and per-problem summary as the
report reads them, written by :func:`vpid_bench.store.archive_pack.write_archive`. Apart from
:mod:`.archive` so that imports go one way: ``pack -> compute -> archive``."""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .. import __version__
from ..store.archive_pack import write_archive
from .compute import compute
from .load import grouped
from .optima import REACHED, load_optima


def pack(sweep_dir: Path, suite: str, out: Path, *, command: str, commit: str | None,
         made_at: str, optima_only: bool = False) -> dict[str, Any]:
    """Write the archive of the sweep in ``sweep_dir`` into ``out``; return its manifest
    (``optima_only``: the instance optima alone, what ``target=`` stops at)."""
    data = compute([sweep_dir], True, 0.05, "random", archive=False)
    optima = load_optima([sweep_dir], data.loaded.records).optima
    return write_archive(out, suite, data.loaded.records, data.rows, optima,
                         summary_rows(data.rows), command=command, commit=commit,
                         made_at=made_at, version=__version__, optima_only=optima_only)


def splice(archive: Path, sweep_dir: Path, replaced: set[str], out: Path, *,
           replacing: Mapping[str, Any]) -> dict[str, Any]:
    """Write into ``out`` the archive in ``archive`` with the runs of the optimizers
    ``replaced`` taken from the sweep in ``sweep_dir`` instead; return its manifest.

    Every other run, optimum and job file is the archive's (a run packed again is the same
    line: :func:`~vpid_bench.store.archive_pack.compact_trace` keeps a cut trace); the
    summary and IOHprofiler export are computed again from the runs together, the optima are
    the lowest of the archive's and the sweep's. The manifest keeps the archive's command and
    commit and adds ``replacing`` (the optimizers, command, commit and time of this sweep) to
    its ``replaced`` list: after a peer's code changed, only its runs are made again
    (docs/sweeps.md, rebuilding after a peer's code changed)."""
    from ..store.archive_records import read_archive

    old = read_archive(archive, optima_only=True)
    data = compute([archive, sweep_dir], True, 0.05, "random", archive=False,
                   keep=lambda r: ("_archive" in r) != (r["optimizer"]["name"] in replaced))
    optima = old.optima + load_optima([sweep_dir], data.loaded.records).optima
    manifest = old.manifest
    return write_archive(out, str(manifest["suite"]), data.loaded.records, data.rows, optima,
                         summary_rows(data.rows), command=str(manifest["command"]),
                         commit=manifest.get("commit"), made_at=str(manifest["made_at"]),
                         version=str(manifest["vpid_bench_version"]),
                         replaced=[*manifest.get("replaced", []), dict(replacing)])


def _median(values: Sequence[float]) -> float:
    """The median of the numbers that are not NaN (NaN when none)."""
    vals = [float(v) for v in values if isinstance(v, (int, float)) and not math.isnan(v)]
    return statistics.median(vals) if vals else math.nan


def summary_rows(rows: Sequence[Mapping[str, Any]]) -> list[list[Any]]:
    """Per problem and optimizer, the row of ``summary.csv``
    (:data:`~vpid_bench.store.archive_pack.SUMMARY_HEADERS`)."""
    groups = grouped(rows, lambda r: (r["problem"], r["algorithm"]))
    out = []
    for (problem, algorithm), g in sorted(groups.items()):
        ok = [r for r in g if r["status"] == "ok"]
        gaps = [float(r.get("rel_gap", math.nan)) for r in ok]
        out.append([problem, algorithm, len(g), len(ok), g[0]["metric_name"],
                    _median([r["metric"] for r in ok]), _median(gaps),
                    sum(1 for v in gaps if v <= REACHED),
                    _median([r["evaluations"] for r in ok]),
                    _median([r["run_time_s"] for r in ok])])
    return out
