"""The ``vpid-bench`` command: read the command line, check everything, hand over to Hydra
(each step: docs/architecture.md, how a command flows). The jobs write their ``job.json``,
the report callback ``report/status.json``: the exit status (docs/sweeps.md) is read from
those files, whatever process ran them. ``VPID_BENCH_DEBUG=1`` shows tracebacks.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import threading
import time
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import OmegaConf

from .. import __version__, interrupts
from ..errors import VpidBenchError
from ..fileio import loads_json, open_append, read_text_limited, write_text_atomic
from ..machine import available_cores, environ
from ..plugins import PluginLoadWarning, Registry
from ..spec import JobSpec
from ..store.archive import evaluation_seconds
from ..store.job_status import write_job_status
from . import preflight
from .argv import parse_command_line
from .callbacks import REPORT_STATUS, REPORT_SUBDIR, ensure_job_dir_resolver, write_report
from .config_store import register_configs
from .progress import SweepProgress, first_line
from .quick_help import help_text
from .resume import FolderLock, collect_job_statuses, new_invocation, resume_command
from .suites import expand_suites

DEBUG_ENV = "VPID_BENCH_DEBUG"
log = logging.getLogger("vpid_bench")


def debug_enabled() -> bool:
    """True when ``VPID_BENCH_DEBUG`` asks for tracebacks."""
    return os.environ.get(DEBUG_ENV, "") not in ("", "0", "false", "no")


def one_line(exc: BaseException) -> str:
    """An exception as one line (not ours: with its type), control characters visible."""
    from ..report.safe import clean

    name = getattr(exc, "remote_type", type(exc).__name__)  # carried from a worker process
    text = " ".join(str(exc).split()) or name
    if isinstance(exc, (VpidBenchError, ValueError)) or getattr(exc, "plain", False):
        return clean(text)
    return clean(f"{name}: {text}")


def _refuse(exc: BaseException) -> NoReturn:
    if debug_enabled():
        raise exc
    print(f"error: {one_line(exc)}", file=sys.stderr, flush=True)
    sys.exit(2)


class JobTask:
    """Hydra's task function: runs one job, writes its ``job.json``, never raises. Registry,
    problem cache and worker processes are not pickled: a launcher's process rebuilds them."""

    __module__ = __name__

    def __init__(self, registry: Any = None) -> None:
        self._registry = registry
        self._problems: Any = None
        self._pool: Any = None
        self.lock: Any = None  # the output folder's FolderLock, in the command's process
        self.not_ok = 0  # jobs of this process that failed or had failed runs
        self.progress: Any = None  # a planned -m sweep's SweepProgress, in the command

    def __getstate__(self) -> dict[str, Any]:
        return {"_registry": None, "_problems": None, "_pool": None, "lock": None, "not_ok": 0,
                "progress": None}

    def close(self) -> None:
        """Stop the sweep's worker processes."""
        if self._pool is not None:
            self._pool.close()

    def __call__(self, cfg: Any) -> float | None:
        interrupts.raise_if_swallowed()  # a Ctrl-C a C callback dropped during the last job
        hydra_cfg = HydraConfig.get()
        job_dir = Path(hydra_cfg.runtime.output_dir)
        multirun = hydra_cfg.mode.name == "MULTIRUN"
        handler = _open_job_log(job_dir)
        try:
            return self._run(cfg, hydra_cfg, job_dir, multirun)
        finally:
            if handler is not None:
                logging.getLogger().removeHandler(handler)
                handler.close()

    def _run(self, cfg: Any, hydra_cfg: Any, job_dir: Path, multirun: bool) -> float | None:
        """Run the job; its search score is what an optimizing sweeper (Optuna) minimises."""
        from ..build import ProblemCache
        from ..experiment import run_from_config
        from ..workers import Workers

        try:
            if self.lock is not None and not self.lock.still_here():
                raise VpidBenchError(f"the output folder {self.lock.folder} was moved, renamed "
                                     "or removed while the command ran (its lock file is gone):"
                                     " this job is not run; finish the sweep where it now is "
                                     "with --resume=<its path>")
            self._registry = self._registry or _load_registry()
            self._problems = self._problems or ProblemCache()
            # Hydra's basic launcher runs jobs in this process, where the sweep's workers
            # serve every job; others' processes (joblib's loky) cannot start spawn children
            basic = str((hydra_cfg.launcher or {}).get("_target_", "")).endswith("BasicLauncher")
            if self._pool is None and basic:
                workers = cfg.get("workers")  # checked by the pre-flight: null or >= 1
                self._pool = Workers(workers if isinstance(workers, int) else available_cores())
                runs = cfg.get("runs")  # their imports overlap this job's set-up; no more
                self._pool.prestart(runs if isinstance(runs, int) else None)  # than its runs
            if hydra_cfg.output_subdir is None:
                _save_job_config(cfg, job_dir)
            # The jobs of a sweep share one folder of instance optima (each polished once).
            optima = Path(str(hydra_cfg.sweep.dir)) / "optima" if multirun else None
            summary = run_from_config(cfg, job_dir, self._registry, self._problems, optima,
                                      self._pool)
        except KeyboardInterrupt:
            _write_status(job_dir, "interrupted", "interrupted by the user")
            raise
        except BaseException as exc:  # noqa: BLE001 - crash isolation (SystemExit too): go on
            if debug_enabled():
                log.exception("job failed")
            print(f"error: {one_line(exc)}" + (f" [{job_dir}]" if multirun else ""),
                  file=sys.stderr, flush=True)
            _write_status(job_dir, "error", one_line(exc))
            self.not_ok += 1
            if self.progress is not None:
                runs = cfg.get("runs") if hasattr(cfg, "get") else None
                self.progress.job_done(0, 0, runs if isinstance(runs, int) else 0)
            return None
        self.not_ok += bool(summary.failed)
        _write_status(job_dir, "failed_runs" if summary.failed else "ok", summary)
        print(f"{summary.optimizer} on {summary.problem}: {summary.ran} run(s) done, "
              f"{summary.skipped} already recorded, {len(summary.failed)} failed, "
              f"{summary.wall_time_s:.1f} s -> {job_dir}", file=sys.stderr, flush=True)
        if self.progress is not None:
            self.progress.job_done(summary.ran, summary.skipped)
        return summary.score


JOB_LOG = "vpid_bench.log"


def _write_status(job_dir: Path, status: str, detail: Any) -> None:
    """``job.json``, or one line when it cannot be written: the sweep goes on."""
    try:
        write_job_status(job_dir, status, detail)
    except OSError as exc:  # the summary finds the planned folder without a job.json
        print(f"error: cannot write the status of {job_dir} ({exc.strerror})", file=sys.stderr,
              flush=True)


class _JobLogHandler(logging.FileHandler):
    """Logging's file handler through ``open_append`` (a planted link is never followed)."""

    def _open(self) -> Any:
        return open_append(Path(self.baseFilename))


def _open_job_log(job_dir: Path) -> logging.Handler | None:
    """The job's log ``vpid_bench.log``, opened here so a folder that cannot be written fails
    its job, not the sweep (Hydra opens its handlers outside any ``try``)."""
    try:
        handler = _JobLogHandler(job_dir / JOB_LOG, encoding="utf-8")
    except OSError:
        return None  # the job will meet the same fault and say so in one line
    handler.setFormatter(logging.Formatter("[%(asctime)s][%(name)s][%(levelname)s] - "
                                           "%(message)s"))
    logging.getLogger().addHandler(handler)
    return handler


def _save_job_config(cfg: Any, job_dir: Path) -> None:
    """``.hydra/config.yaml``, ``hydra.yaml`` and ``overrides.yaml`` as Hydra saves them,
    atomically and inside the job's error handling (our ``hydra.output_subdir`` is null)."""
    full = HydraConfig.instance().cfg
    folder = job_dir / ".hydra"
    if folder.is_symlink():  # planted: never written through (issue 24); a folder of our own
        folder.unlink()
    write_text_atomic(folder / "config.yaml", OmegaConf.to_yaml(cfg))
    write_text_atomic(folder / "hydra.yaml", OmegaConf.to_yaml(full))
    write_text_atomic(folder / "overrides.yaml", OmegaConf.to_yaml(full.hydra.overrides.task))


def _load_registry() -> Any:
    """The plugin registry; a plugin that fails to import or register is reported once."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PluginLoadWarning)
        registry = Registry()
    seen = set()
    for w in caught:
        if issubclass(w.category, PluginLoadWarning):
            text = str(w.message)
            if text not in seen:
                seen.add(text)
                print(f"warning: {text}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return registry


def _hydra_entry(argv: Sequence[str], task: Any) -> None:
    decorated = hydra.main(version_base="1.3", config_path="pkg://vpid_bench.conf",
                           config_name="config")(task)
    saved = sys.argv
    sys.argv = [saved[0] if saved else "vpid-bench", *argv]
    try:
        decorated()
    finally:
        sys.argv = saved


def print_versions(registry: Any) -> None:
    """vpid-bench's version, then every plugin's distribution and version."""
    print(f"vpid-bench {__version__}")
    for plugin, source in sorted(registry.info.sources.items()):
        where = f"{source.get('distribution')} {source.get('version')}" if source else "?"
        print(f"  plugin {plugin}: {where}")


def _failures(folder: Path | None, multirun: bool,
              planned: Sequence[Path] = (), report_expected: bool = False) -> list[str]:
    """What went wrong, read from the disk; prints the sweep summary."""
    if folder is None:
        return []
    invocation = os.environ.get("VPID_BENCH_INVOCATION")
    statuses = collect_job_statuses(folder, invocation)
    seen = {os.path.abspath(s["job_dir"]) for s in statuses}
    for job_dir in planned:
        if os.path.abspath(job_dir) not in seen:
            statuses.append({"status": "error", "detail": "job.json not written (the job could "
                             "not write into its folder; its error line above says why)",
                             "job_dir": str(job_dir)})
    bad = [s for s in statuses if s.get("status") != "ok"]
    out = []
    if multirun:
        print(f"sweep: {len(statuses)} job(s), {len(statuses) - len(bad)} ok, {len(bad)} not "
              f"ok -> {folder}", file=sys.stderr)
    for s in bad:
        detail = s.get("detail")
        if isinstance(detail, dict):
            detail = f"runs {detail.get('failed')} failed (their records hold the errors)"
        line = f"  {s.get('status')}: {s['job_dir']}: {detail}"
        if multirun:
            print(line, file=sys.stderr)
        out.append(line)
    try:
        report = loads_json(read_text_limited(folder / REPORT_SUBDIR / REPORT_STATUS))
    except (OSError, ValueError):
        report = None
    mine = isinstance(report, dict) and report.get("invocation") == invocation
    if mine and report.get("status") in ("failed", "problems"):
        out.append(f"report: {report.get('status')}")
    elif report_expected and not mine:  # e.g. a full disk: neither report nor status written
        out.append("report: not written (its status file is missing; the line above says why)")
    return out


def main(argv: Sequence[str] | None = None) -> None:
    """The command ``vpid-bench``: a Ctrl-C at any moment is one line and status 130 (once
    a 35-54-line traceback during the imports and the pre-flight)."""
    if argv is None:  # the console command: a Ctrl-C while it starts is noted, not lost
        interrupts.defer()
    try:
        _main(argv)
    except KeyboardInterrupt:
        _interrupted()
    except Exception:  # a library's error over the user's Ctrl-C (interrupts.seen) is it
        if interrupts.seen():
            _interrupted()
        raise


def _interrupted(what: str = "no job was started or every completed run is recorded; run "
                 "the same command with --resume to continue") -> NoReturn:
    """One ``interrupted:`` line and the status of the signal (SIGINT, SIGTERM, SIGHUP)."""
    with contextlib.suppress(OSError):  # SIGHUP: the terminal may be gone
        print(f"interrupted: {what}", file=sys.stderr)
    sys.exit(interrupts.exit_status())


def _main(argv: Sequence[str] | None) -> None:
    threading.excepthook = (  # a plugin's own thread's exception: one line, no traceback
        lambda args: print(interrupts.thread_exception_line(args), file=sys.stderr))
    before = set(threading.enumerate())
    console = argv is None  # the console command, not a call from another program
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        cmd = parse_command_line(argv)
        registry = _load_registry()  # the plugins' imports: still deferred (see main)
        cmd = expand_suites(cmd, registry)
    except VpidBenchError as exc:
        _refuse(exc)
    if console:
        interrupts.install()  # raises a Ctrl-C noted during the start-up
    if cmd.version:
        print_versions(registry)
        return
    new_invocation()
    register_configs(registry)
    ensure_job_dir_resolver()
    task = JobTask(registry)
    if cmd.info in ("--help", "--hydra-help", "--shell-completion"):
        _quick_help(cmd, registry) or _run_hydra(cmd.hydra_args, task)  # the information
        sys.exit(1 if task.not_ok else 0)
    try:
        plan = preflight.plan(cmd, registry)
        if cmd.info is not None:  # --cfg, --info: checked, now shown by Hydra
            _run_hydra(cmd.hydra_args, task)
            return
        key = "hydra.sweep.dir" if plan.multirun else "hydra.run.dir"
        lock = _prepare_folder(plan, key, task)
        nothing_to_run = _nothing_to_run(plan, registry, task)
    except VpidBenchError as exc:
        _refuse(exc)
    if nothing_to_run:
        _report_only(plan, task, lock, before, watch=console)
        return
    try:
        _run_hydra(plan.hydra_args, task)
    except KeyboardInterrupt:
        _interrupted("every completed run is recorded; to continue (only missing runs are "
                     f"run): {resume_command(argv, plan.output_dir, key)}")
    finally:
        task.close()
        lock.release()
    _leave(1 if _failures(plan.output_dir, plan.multirun, plan.job_dirs,
                          report_expected=bool(plan.jobs) and plan.jobs[0].spec.report)
           else 0, before, watch=console, grace_s=_grace(plan))


def _prepare_folder(plan: Any, key: str, task: JobTask) -> Any:
    """The output folder checked, locked (returned) and its job folders made."""
    lock = FolderLock(plan.output_dir, key)
    preflight.check_writable(plan.output_dir, key)
    lock.acquire()
    task.lock, task.progress, task._problems = lock, _sweep_progress(plan), plan.problems
    preflight.create_job_dirs(plan)
    return lock


def _nothing_to_run(plan: Any, registry: Any, task: JobTask) -> bool:
    """Whether the sweep has nothing to run; else its first progress line (how long)."""
    from ..experiment import recorded_in_full
    if plan.multirun and recorded_in_full(plan.jobs, plan.job_dirs, registry, plan.problems):
        return True
    if task.progress is not None:
        print(first_line(plan.jobs, evaluation_seconds()), file=sys.stderr, flush=True)
    return False


def _report_only(plan: Any, task: JobTask, lock: Any, before: set[Any], watch: bool) -> None:
    """A sweep whose every run is recorded: say so and write its report again (archives or
    the report's code may have changed), nothing else; status 1 when the report failed."""
    runs = sum(j.spec.runs for j in plan.jobs)
    print(f"sweep folder: {plan.output_dir}\n  nothing to run: the {len(plan.jobs)} job(s)' "
          f"{runs} run(s) are all recorded under these settings, plugins and data; only the "
          "report is written again", file=sys.stderr, flush=True)
    spec = plan.jobs[0].spec
    try:
        ok = write_report(plan.output_dir, short=False, archive=spec.archive) \
            if spec.report else True
    finally:
        task.close()
        lock.release()
    _leave(0 if ok else 1, before, watch, _grace(plan))


def _quick_help(cmd: Any, registry: Any) -> bool:
    """Print the help page without Hydra's machinery; False when Hydra must build it."""
    if cmd.info != "--help":
        return False
    try:
        text = help_text(cmd, registry)
    except VpidBenchError as exc:
        _refuse(exc)
    if text is None:
        return False
    print(text, end="" if text.endswith("\n") else "\n")
    return True


def _sweep_progress(plan: Any) -> Any:
    """The progress line of a ``-m`` sweep whose jobs the plan knows (and progress=true)."""
    if not plan.multirun or not plan.jobs or not all(j.spec.progress for j in plan.jobs):
        return None
    return SweepProgress(len(plan.jobs), sum(j.spec.runs for j in plan.jobs))


def _grace(plan: Any) -> float:
    """The sweep's ``grace_s`` (its first job's: the key is top-level), else its default."""
    return float(plan.jobs[0].spec.grace_s) if plan.jobs else JobSpec.grace_s


def _leave(code: int, before: set[Any], watch: bool, grace_s: float) -> None:
    """End the command with ``code``. A non-daemon thread a plugin left running (not one of
    ``before``) would keep the process alive for ever: with ``watch`` (the console command),
    a watchdog gives the shutdown ``grace_s`` (the sweep's key), then names them and exits."""
    mine = [t for t in threading.enumerate() if t is not threading.main_thread()
            and not t.daemon and t not in before]
    if watch and mine:
        def watchdog() -> None:
            time.sleep(grace_s)
            names = ", ".join(t.name for t in mine if t.is_alive()) or "?"
            print(f"warning: thread(s) {names} started by a plugin still run "
                  f"{grace_s:g} s after the end (grace_s); exiting without them (every "
                  "record is written)", file=sys.stderr)
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)

        threading.Thread(target=watchdog, name="vpid-bench-exit-watchdog", daemon=True).start()
    if code:
        sys.exit(code)


def _run_hydra(args: list[str], task: Any) -> None:
    """Hydra's run; its refusals become one line, exit 2. Hydra raises its errors
    (``HYDRA_FULL_ERROR``), so one a Ctrl-C caused is told from a refusal and ends the
    command as the Ctrl-C does."""
    try:
        with environ("HYDRA_FULL_ERROR", "1"):  # read by Hydra when an error reaches it
            _hydra_entry(args, task)
        interrupts.raise_if_swallowed()  # a Ctrl-C a C callback dropped during the last job
    except SystemExit as exc:
        if exc.code not in (0, None):
            if interrupts.seen():
                raise KeyboardInterrupt from None
            sys.exit(2)
        raise
    except KeyboardInterrupt:
        raise
    except Exception as exc:  # noqa: BLE001 - a Hydra error outside any job
        if interrupts.seen():
            raise KeyboardInterrupt from None
        cause = exc.__cause__  # the omegaconf error under it, in one message as Hydra says
        _refuse(exc if cause is None or str(cause) in str(exc)
                else VpidBenchError(f"{one_line(exc)}: {one_line(cause)}"))


if __name__ == "__main__":  # pragma: no cover
    main()
