"""The ``vpid-bench`` command: a thin Hydra shell around :func:`run_from_config`.

Start-up: load the plugins (entry points of group ``vpid_bench``), store a Hydra config node
per registered problem and optimizer, check the command-line overrides against them
(:mod:`vpid_bench.preflight`), then hand over to Hydra. Every job catches every error and
prints it as one line (set ``VPID_BENCH_DEBUG=1`` for the traceback); its ``job.json`` says
what happened, and the command reads them all at the end, whatever launcher ran the jobs.

``--resume`` (our only flag, removed before Hydra sees the command line) re-uses the newest
earlier sweep (``-m``) or run whose overrides match, so only missing runs are run again;
``--resume=<folder>`` names the folder.

Exit status: 0 all runs ok; 1 some run or job failed (records and ``job.json`` say why);
2 the command was refused before anything ran (bad override, plugin collision, unwritable
output folder); 130 interrupted (every completed run is kept).
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .api import VpidBenchError

DEBUG_ENV = "VPID_BENCH_DEBUG"
RESUME_FLAG = "--resume"
log = logging.getLogger("vpid_bench")

# Failures seen in this process (jobs of the basic launcher, single runs, callbacks);
# read by main() to choose the exit status.
_FAILURES: list[str] = []


def debug_enabled() -> bool:
    """True when ``VPID_BENCH_DEBUG`` asks for tracebacks."""
    return os.environ.get(DEBUG_ENV, "") not in ("", "0", "false", "no")


def note_failure(message: str) -> None:
    """Remember that something failed, so the command exits non-zero."""
    _FAILURES.append(message)


def _one_line(exc: BaseException) -> str:
    """An exception as one line: our own errors as they are, others with their type."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, (VpidBenchError, ValueError)):
        return text
    return f"{type(exc).__name__}: {text}"


def _job(cfg: Any) -> None:
    """One Hydra job: run it, write its job status, never raise (one failed job must not
    stop the sweep)."""
    from hydra.core.hydra_config import HydraConfig

    from .experiment import run_from_config
    from .jobstatus import write_job_status

    job_dir = Path(HydraConfig.get().runtime.output_dir)
    try:
        summary = run_from_config(cfg, job_dir)
    except KeyboardInterrupt:
        write_job_status(job_dir, "interrupted", "interrupted by the user")
        raise
    except Exception as exc:  # noqa: BLE001 - crash isolation: report, let the sweep go on
        if debug_enabled():
            log.exception("job failed")
        else:
            log.debug("job failed", exc_info=True)  # the traceback goes to the job's log
        message = f"error: {_one_line(exc)}"
        print(message + (f" [{job_dir}]" if HydraConfig.get().mode.name == "MULTIRUN" else ""),
              file=sys.stderr, flush=True)
        # If the output folder itself is the problem, the message above says so.
        with contextlib.suppress(OSError):
            write_job_status(job_dir, "error", _one_line(exc))
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
        flush=True,
    )


def _hydra_entry(argv: Sequence[str]) -> None:
    import hydra

    decorated = hydra.main(
        version_base="1.3", config_path="pkg://vpid_bench.conf", config_name="config"
    )(_job)
    saved = sys.argv
    sys.argv = [saved[0] if saved else "vpid-bench", *argv]
    try:
        decorated()
    finally:
        sys.argv = saved


def _load_registry() -> Any:
    """The plugin registry; a plugin that fails to import is reported in one line."""
    from .plugins import PluginLoadWarning, Registry

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PluginLoadWarning)
        registry = Registry()
    for w in caught:
        if issubclass(w.category, PluginLoadWarning):
            print(f"warning: {w.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return registry


def _split_resume(argv: Sequence[str]) -> tuple[list[str], str | None]:
    """``argv`` without ``--resume[=folder]``, and the flag's value ("" = find it)."""
    rest, resume = [], None
    for arg in argv:
        if arg == RESUME_FLAG:
            resume = ""
        elif arg.startswith(RESUME_FLAG + "="):
            resume = arg.split("=", 1)[1]
        else:
            rest.append(arg)
    return rest, resume


def _preflight(argv: list[str], registry: Any, resume: str | None) -> list[str]:
    """Check the command line; resolve ``--resume``; check the output folder is writable.

    Returns the command line for Hydra (with the folder to resume, if any).
    """
    from . import preflight
    from .api import ConfigError
    from .sweep import find_previous

    cmd = preflight.split_command_line(argv)
    if cmd is None or cmd.custom_config:
        return argv  # Hydra reports / handles these itself
    primary = preflight.primary_config()
    preflight.check_overrides(cmd.overrides, registry, preflight.default_choices(primary))
    if cmd.info_only:
        return argv
    dir_key = "hydra.sweep.dir" if cmd.multirun else "hydra.run.dir"
    given = [o.split("=", 1)[1] for o in cmd.overrides if o.startswith(dir_key + "=")]
    template = given[-1] if given else preflight.raw_output_dir(primary, cmd.multirun)
    if resume is not None and not given:
        if resume:
            folder = Path(resume)
            if not folder.is_dir():
                raise ConfigError("--resume", resume, "an existing sweep or run folder")
        else:
            root = preflight.output_root(template)
            folder = find_previous(root, cmd.overrides, cmd.multirun)
            if folder is None:
                print(f"resume: no earlier {'sweep' if cmd.multirun else 'run'} under {root} "
                      "has these overrides; starting a new one", file=sys.stderr)
        if folder is not None:
            print(f"resume: continuing {folder}", file=sys.stderr)
            argv = [*argv, f"{dir_key}={folder}"]
            template = str(folder)
    preflight.check_writable(preflight.output_root(template) if "${" in template
                             else Path(template), dir_key)
    return argv


def _sweep_failures() -> list[str]:
    """Failures recorded in the ``job.json`` files of the sweep this command just ran."""
    from .sweep import collect_job_statuses, current_invocation, current_sweep_dir

    sweep_dir = current_sweep_dir()
    if sweep_dir is None:
        return []
    statuses = collect_job_statuses(sweep_dir, current_invocation())
    bad = [s for s in statuses if s.get("status") != "ok"]
    print(f"sweep: {len(statuses)} job(s), {len(statuses) - len(bad)} ok, {len(bad)} not ok"
          f" -> {sweep_dir}", file=sys.stderr)
    out = []
    for s in bad:
        detail = s.get("detail")
        if isinstance(detail, dict):
            detail = f"runs {detail.get('failed')} failed (their records hold the errors)"
        line = f"  {s['status']}: {s['job_dir']}: {detail}"
        print(line, file=sys.stderr)
        out.append(line)
    return out


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point ``vpid-bench``."""
    from .config_store import register_configs
    from .sweep import new_invocation

    argv, resume = _split_resume(sys.argv[1:] if argv is None else argv)
    _FAILURES.clear()
    new_invocation()
    try:
        registry = _load_registry()
        register_configs(registry)
    except VpidBenchError as exc:
        if debug_enabled():
            raise
        print(f"error: {_one_line(exc)}", file=sys.stderr)
        sys.exit(2)
    try:
        argv = _preflight(argv, registry, resume)
    except VpidBenchError as exc:
        if debug_enabled():
            raise
        print(f"error: {_one_line(exc)}", file=sys.stderr)
        sys.exit(2)
    except Exception as exc:  # noqa: BLE001 - a pre-flight bug must not block a valid command
        if debug_enabled():
            raise
        print(f"warning: pre-flight check skipped ({_one_line(exc)})", file=sys.stderr)
    try:
        _hydra_entry(argv)
    except KeyboardInterrupt:
        print(
            "interrupted: every completed run is recorded; run the same command with "
            f"{RESUME_FLAG} to continue (only missing runs are run)",
            file=sys.stderr,
        )
        sys.exit(130)
    failures = _sweep_failures() or _FAILURES
    if failures or _FAILURES:
        sys.exit(1)


if __name__ == "__main__":  # pragma: no cover
    main()
