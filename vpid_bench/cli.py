"""The ``vpid-bench`` command: a thin Hydra shell around :func:`run_from_config`.

Start-up: load the plugins (entry points of group ``vpid_bench``), store a Hydra config node
per registered problem and optimizer, then hand over to Hydra. Every job catches the errors
this package raises on purpose and prints them as one line (set ``VPID_BENCH_DEBUG=1`` for
the traceback); the command exits non-zero when any job or run failed.
"""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path
from typing import Any

from .api import VpidBenchError

DEBUG_ENV = "VPID_BENCH_DEBUG"
log = logging.getLogger("vpid_bench")

# Set by the job function in this process (basic launcher, single runs) and by the sweep
# callback (any launcher); read by main() to choose the exit status.
_FAILURES: list[str] = []


def debug_enabled() -> bool:
    """True when ``VPID_BENCH_DEBUG`` asks for tracebacks."""
    return os.environ.get(DEBUG_ENV, "") not in ("", "0", "false", "no")


def note_failure(message: str) -> None:
    """Remember that something failed, so the command exits non-zero."""
    _FAILURES.append(message)


def _job(cfg: Any) -> None:
    """One Hydra job: run it, write its job status, never raise for expected errors."""
    from hydra.core.hydra_config import HydraConfig

    from .experiment import run_from_config
    from .jobstatus import write_job_status

    hc = HydraConfig.get()
    job_dir = Path(hc.runtime.output_dir)
    try:
        summary = run_from_config(cfg, job_dir)
    except KeyboardInterrupt:
        write_job_status(job_dir, "interrupted", "interrupted by the user")
        raise
    except (VpidBenchError, ValueError) as exc:
        if debug_enabled():
            log.exception("job failed")
        message = f"error: {exc}"
        print(message, file=sys.stderr)
        write_job_status(job_dir, "error", str(exc))
        note_failure(message)
        return
    status = "failed_runs" if summary.failed else "ok"
    write_job_status(job_dir, status, summary)
    if summary.failed:
        note_failure(f"{len(summary.failed)} failed run(s) in {job_dir}")
    print(
        f"{summary.optimizer} on {summary.problem}: {summary.ran} run(s) done, "
        f"{summary.skipped} already recorded, {len(summary.failed)} failed, "
        f"{summary.wall_time_s:.1f} s -> {job_dir}",
        file=sys.stderr,
    )


def _hydra_entry() -> None:
    import hydra

    decorated = hydra.main(
        version_base="1.3", config_path="pkg://vpid_bench.conf", config_name="config"
    )(_job)
    decorated()


def main() -> None:
    """Console entry point ``vpid-bench``."""
    from .config_store import register_configs
    from .plugins import Registry

    _FAILURES.clear()
    try:
        registry = Registry()
        register_configs(registry)
    except VpidBenchError as exc:
        if debug_enabled():
            raise
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    try:
        _hydra_entry()
    except KeyboardInterrupt:
        print(
            "interrupted: every completed run is recorded; run the same command again to "
            "resume (for a sweep, add hydra.sweep.dir=<the sweep folder printed above>)",
            file=sys.stderr,
        )
        sys.exit(130)
    if _FAILURES:
        sys.exit(1)


if __name__ == "__main__":  # pragma: no cover
    main()
