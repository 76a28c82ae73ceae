"""Hydra callback: a report at the end of every sweep and every single job.

Registered in ``conf/config.yaml`` under ``hydra.callbacks.report``. At the end of a
multirun it writes the report into ``<sweep dir>/report/`` and prints the headline table;
at the end of a single job it writes the light report (:mod:`.light`: numpy and tabulate
only, no figures) into ``<job dir>/report/report.md``. The top-level key ``report: false``
turns it off.

A report never crashes the command: any exception becomes one printed line and a noted
failure (non-zero exit). Importing this module is cheap: the full report's code (pandas,
seaborn, matplotlib, scikit-posthocs) is imported only when a sweep's report is built, never
for a single job.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback

log = logging.getLogger(__name__)
REPORT_SUBDIR = "report"


def _note_failure(message: str) -> None:
    from ..cli import note_failure

    note_failure(message)


def _enabled(config: Any) -> bool:
    try:
        return bool(config.get("report", True))
    except Exception:  # an odd config must not stop the command here
        return True


def _run_dir(config: Any) -> Path:
    """The single job's output folder."""
    try:
        out = config.hydra.runtime.output_dir
        if out:
            return Path(str(out))
    except Exception:
        pass
    try:
        from hydra.core.hydra_config import HydraConfig

        return Path(str(HydraConfig.get().runtime.output_dir))
    except Exception:
        return Path(str(config.hydra.run.dir))


def write_and_print(folder: Path, short: bool) -> bool:
    """Build the report of ``folder`` into ``folder/report``, print where and the headline.

    ``short``: the light single-job report (:func:`.light.light_report`, no pandas, no
    figures); else the full report. Returns True on success; on any error prints one line,
    notes a failure, returns False.
    """
    try:
        from .build import build_report

        report: Any = build_report([folder], folder / REPORT_SUBDIR, short=short)
    except Exception as exc:  # the report must not crash a sweep
        from .load import NoRecordsError

        if isinstance(exc, NoRecordsError):  # every job failed: its error line said why
            print(f"report: none, no run was recorded in {folder}", file=sys.stderr, flush=True)
            return False
        log.debug("report failed", exc_info=True)
        message = f"report: not written for {folder} ({type(exc).__name__}: {exc})"
        print(message, file=sys.stderr, flush=True)
        _note_failure(message)
        return False
    print(f"\n{report.headline}\n\nreport: {report.report_md}", flush=True)
    if short:
        from .build import full_report_command

        print(f"full report with figures: {full_report_command(folder)}", flush=True)
    bad = report.failures
    if bad:
        print(f"report: {len(bad)} problem(s) found, listed in the report: " + "; ".join(bad[:3])
              + (" ..." if len(bad) > 3 else ""), file=sys.stderr, flush=True)
        _note_failure(f"report found {len(bad)} problem(s) in {folder}")
    return True


class ReportCallback(Callback):
    """Writes the report at the end of a sweep (full) and of a single job (short)."""

    def on_multirun_end(self, config: Any, **kwargs: Any) -> None:
        if _enabled(config):
            write_and_print(Path(str(config.hydra.sweep.dir)), short=False)

    def on_run_end(self, config: Any, **kwargs: Any) -> None:
        if _enabled(config):
            write_and_print(_run_dir(config), short=True)
