"""Helpers for the hostile-input tests: the real command in a subprocess or in-process, and
folders that cannot be written (for root too)."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import pytest
from extras import limit

CLI = [sys.executable, "-c", "from vpid_bench.shell.main import main; main()"]
REPORT_CLI = [sys.executable, "-c", "from vpid_bench.report.cli import main; main()"]
#: A tiny job: a sweep point that passes runs in well under a second.
TINY = ["problem=functions", "optimizer=random", "runs=1", "problem.iterations=2",
        "progress=false", "report=false"]


def cli_env(extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """A headless environment without debug tracebacks."""
    env = {k: v for k, v in os.environ.items() if k != "VPID_BENCH_DEBUG"}
    env["MPLBACKEND"] = "Agg"
    env.update(extra or {})
    return env


def run_cli(args: Sequence[str], cwd: Path, env: Mapping[str, str] | None = None,
            timeout: float = 120, report: bool = False) -> subprocess.CompletedProcess:
    """``vpid-bench <args>`` (or ``vpid-bench-report``) in ``cwd``, text output."""
    return subprocess.run([*(REPORT_CLI if report else CLI), *args], cwd=cwd,
                          env=cli_env(env), capture_output=True, text=True, timeout=limit(timeout),
                          check=False)


def main_in_process(argv: Sequence[str], capsys) -> tuple[int, str]:
    """``vpid_bench.shell.main.main(argv)`` in this process: (exit code, stderr)."""
    from vpid_bench.shell.main import main

    try:
        main(list(argv))
        code = 0
    except SystemExit as exc:
        code = 0 if exc.code is None else exc.code
    return code, capsys.readouterr().err


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("error:")]


@contextlib.contextmanager
def read_only(folder: Path) -> Iterator[Path]:
    """``folder`` made unwritable for the duration: ``chmod 555`` for a normal user; root
    ignores modes, so for root the immutable attribute (``chattr +i``) is used, or the test
    is skipped where it is unavailable."""
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        folder.chmod(0o555)
        try:
            yield folder
        finally:
            folder.chmod(0o755)
        return
    chattr = shutil.which("chattr")
    if chattr is None or subprocess.run([chattr, "+i", str(folder)],
                                        capture_output=True).returncode != 0:
        pytest.skip("running as root without chattr +i: cannot make a read-only folder")
    try:
        yield folder
    finally:
        subprocess.run([chattr, "-i", str(folder)], check=False)


def plan_of(argv: Sequence[str]):
    """The pre-flight's plan of ``vpid-bench <argv>`` (the config nodes registered first, as
    the command does)."""
    from vpid_bench.plugins import Registry
    from vpid_bench.shell.argv import parse_command_line
    from vpid_bench.shell.callbacks import ensure_job_dir_resolver
    from vpid_bench.shell.config_store import register_configs
    from vpid_bench.shell.preflight import plan

    registry = Registry()
    register_configs(registry)
    ensure_job_dir_resolver()
    return plan(parse_command_line(list(argv)), registry)
