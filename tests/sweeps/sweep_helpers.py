"""Helpers for the sweep tests: run the real ``vpid-bench`` command in a subprocess."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from extras import limit

from vpid_bench.store import records as rec

CLI = [sys.executable, "-c", "from vpid_bench.shell.main import main; main()"]


def cli_env(extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """The environment of a CLI subprocess: headless, no debug tracebacks."""
    env = {k: v for k, v in os.environ.items() if k not in ("VPID_BENCH_DEBUG",)}
    env["MPLBACKEND"] = "Agg"
    env.update(extra or {})
    return env


def run_cli(
    args: Sequence[str], cwd: Path, env: Mapping[str, str] | None = None, timeout: float = 120
) -> subprocess.CompletedProcess:
    """``vpid-bench <args>`` in ``cwd``; returns the completed process (text output)."""
    return subprocess.run(
        [*CLI, *args], cwd=cwd, env=cli_env(env), capture_output=True, text=True,
        timeout=limit(timeout), check=False,
    )


def fingerprints(sweep_dir: Path) -> dict[str, str]:
    """Record path (relative to the sweep) -> fingerprint, for every record below it."""
    sweep_dir = Path(sweep_dir)
    return {
        str(p.relative_to(sweep_dir)): rec.fingerprint(rec.read_record(p))
        for p in rec.iter_record_files([sweep_dir])
    }



def planned_job_dirs(args: Sequence[str]) -> list[Path]:
    """The job folders the pre-flight plans for ``vpid-bench <args>`` (a sweep)."""
    from vpid_bench.plugins import Registry
    from vpid_bench.shell.argv import parse_command_line
    from vpid_bench.shell.callbacks import ensure_job_dir_resolver
    from vpid_bench.shell.config_store import register_configs
    from vpid_bench.shell.preflight import plan

    registry = Registry()
    register_configs(registry)
    ensure_job_dir_resolver()
    return plan(parse_command_line(list(args)), registry).job_dirs
