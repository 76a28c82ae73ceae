"""Hydra callbacks (listed in ``conf/config.yaml``): :class:`SweepStatus`, :class:`ReportCallback`.
They write their outcome to disk, never into process-global state, so the command reads it
whatever process ran the jobs; both register the ``vpid_bench_job_dir`` resolver (safe job
folder names) in every process that resolves job folders.
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
import shlex
import sys
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback
from omegaconf import OmegaConf

from ..fileio import own_folder
from ..progress import Stages
from ..store.records import write_json_atomic

log = logging.getLogger(__name__)
REPORT_SUBDIR = "report"
REPORT_STATUS = "status.json"
JOB_DIR_RESOLVER = "vpid_bench_job_dir"
#: Longest job folder name; longer names end in a hash of the whole name.
MAX_JOB_DIR = 120
INVOCATION_ENV = "VPID_BENCH_INVOCATION"

_UNSAFE = re.compile(r"[^A-Za-z0-9._=,+@-]")


def job_dir_name(override_dirname: str) -> str:
    """A job folder name made from its overrides: one path component (no ``/``, never ``.``
    or ``..``), at most :data:`MAX_JOB_DIR` characters; unsafe characters become ``%XX``."""
    text = str(override_dirname) or "job"
    safe = _UNSAFE.sub(lambda m: "".join(f"%{b:02X}" for b in m.group().encode()), text)
    if safe in (".", ".."):
        safe = safe.replace(".", "%2E")
    if len(safe) > MAX_JOB_DIR:
        digest = hashlib.sha256(text.encode()).hexdigest()[:12]
        safe = safe[: MAX_JOB_DIR - 13] + "~" + digest
    return safe


def ensure_job_dir_resolver() -> None:
    """Register the ``${vpid_bench_job_dir:...}`` resolver in this process (idempotent)."""
    if not OmegaConf.has_resolver(JOB_DIR_RESOLVER):
        OmegaConf.register_new_resolver(JOB_DIR_RESOLVER, job_dir_name)


class _ResolverCallback(Callback):
    def __init__(self, **kwargs: Any) -> None:
        ensure_job_dir_resolver()

    def __getstate__(self) -> dict[str, Any]:  # never empty: pickle then calls __setstate__
        return {**self.__dict__, "_needs_resolver": True}

    def __setstate__(self, state: dict[str, Any]) -> None:  # unpickled in a launcher worker
        self.__dict__.update(state)
        ensure_job_dir_resolver()


class SweepStatus(_ResolverCallback):
    """Prints the sweep folder and the command that resumes it."""

    def on_multirun_start(self, config: Any, **kwargs: Any) -> None:
        sweep_dir = Path(str(config.hydra.sweep.dir))
        args = [a for a in sys.argv[1:] if not a.startswith("hydra.sweep.dir=")]
        hint = shlex.join(["vpid-bench", *args, f"hydra.sweep.dir={sweep_dir}"])
        print(f"sweep folder: {sweep_dir}\n"
              f"  if this sweep stops, resume it (only missing runs are run) with:\n  {hint}\n"
              "  (or run the same command with --resume: it finds the newest sweep like it)",
              file=sys.stderr, flush=True)


def _enabled(config: Any, key: str = "report") -> bool:
    try:
        return bool(config.get(key, True))
    except Exception:  # an odd config must not stop the command here
        return True


def write_report(folder: Path, short: bool, archive: bool = True) -> bool:
    """Build the report of ``folder`` into ``folder/report`` (whole, or the previous one
    kept with one ``warning:`` line), print the headline and where it is, and write the
    outcome into ``report/status.json``. Never raises."""
    from ..report.build import NoRecordsError, build_report
    from ..report.safe import clean  # every line may quote records or archives

    out = folder / REPORT_SUBDIR
    status: dict[str, Any] = {"status": "ok", "problems": [],
                              "invocation": os.environ.get(INVOCATION_ENV)}
    try:
        own_folder(out)  # a link planted there: removed, never written through
        report = build_report([folder], out, short=short, archive=archive,
                              progress=None if short else Stages("report"))
    except NoRecordsError:  # every job failed: its own error line said why
        print(f"report: none, no run was recorded in {folder}", file=sys.stderr, flush=True)
        status["status"] = "no_records"
    except Exception as exc:  # noqa: BLE001 - the report must not crash a sweep
        log.debug("report failed", exc_info=True)
        message = clean(f"warning: the report was not written for {folder} "
                        f"({type(exc).__name__}: {exc}); {out} keeps the previous one, if any")
        print(message, file=sys.stderr, flush=True)
        status.update(status="failed", problems=[message])
    else:
        for note in [*report.folder_notes, *report.archive_notes]:
            print(clean(note), file=sys.stderr, flush=True)
        print(f"\n{clean(report.headline, keep_newlines=True)}\n\nreport: "
              f"{clean(report.report_md)}", flush=True)
        if report.index_html is not None:
            print(f"html: {clean(report.index_html)}", flush=True)
        if short:
            print(f"report with figures and statistics: vpid-bench-report {folder} -o "
                  f"{folder / 'report-full'}", flush=True)
        bad = list(report.failures)
        if bad:
            print(f"report: {len(bad)} problem(s) found, listed in the report: "
                  + "; ".join(clean(b) for b in bad[:3]) + (" ..." if len(bad) > 3 else ""),
                  file=sys.stderr, flush=True)
            status.update(status="problems", problems=bad)
    try:
        write_json_atomic(out / REPORT_STATUS, status)
    except OSError as exc:
        print(f"report: cannot write {out / REPORT_STATUS} ({exc.strerror})", file=sys.stderr)
    return status["status"] == "ok"


class ReportCallback(_ResolverCallback):
    """Writes the report at the end of a sweep (full) and of a single job (short)."""

    def on_multirun_end(self, config: Any, **kwargs: Any) -> None:
        if _enabled(config):
            write_report(Path(str(config.hydra.sweep.dir)), short=False,
                         archive=_enabled(config, "archive"))

    def on_run_end(self, config: Any, **kwargs: Any) -> None:
        if _enabled(config):
            write_report(Path(str(config.hydra.runtime.output_dir)), short=True,
                         archive=_enabled(config, "archive"))
