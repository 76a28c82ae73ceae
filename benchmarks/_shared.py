"""What the benchmark scripts share: how to call the two commands in a child process, with
what environment, and how to compose a job's config in this process as the command does.

The scripts import it as ``_shared`` (they run as ``python benchmarks/<script>.py``, which
puts this folder first on ``sys.path``)."""

from __future__ import annotations

import os
import sys
import tempfile
from typing import Any

#: ``vpid-bench`` and ``vpid-bench-report`` in a child process of this interpreter (the
#: virtual environment's, whatever is first on PATH).
CLI = [sys.executable, "-c", "from vpid_bench.shell.main import main; main()"]
REPORT = [sys.executable, "-c", "from vpid_bench.report.cli import main; main()"]


def cli_env() -> dict[str, str]:
    """The environment of a child command: headless matplotlib with its own config folder
    (unless the caller set them)."""
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    env.setdefault("MPLCONFIGDIR", tempfile.mkdtemp(prefix="vpid-mpl-"))
    return env


def registry_with_configs() -> Any:
    """The installed plugins' registry, their config nodes stored in Hydra's ConfigStore
    (once per process, before :func:`compose`)."""
    from vpid_bench.plugins import Registry
    from vpid_bench.shell.config_store import register_configs

    registry = Registry()
    register_configs(registry)
    return registry


def compose(overrides: list[str]) -> Any:
    """The job config the command would compose for ``overrides`` (Hydra's global state
    cleared before; the config nodes stored by :func:`registry_with_configs`)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_module
    from hydra.core.global_hydra import GlobalHydra

    GlobalHydra.instance().clear()
    with initialize_config_module(version_base="1.3", config_module="vpid_bench.conf"):
        return hydra_compose(config_name="config", overrides=list(overrides))


def run_timed(cmd: list[str], cwd: Any) -> tuple[float, float]:
    """Run ``cmd`` in ``cwd`` (it must succeed: else exit with the end of its stderr);
    return its wall seconds and its CPU seconds (user + system of the child, which vary
    much less than the wall time on a machine shared with other work)."""
    import resource
    import subprocess
    import time

    def children_cpu() -> float:
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    c0, t0 = children_cpu(), time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, env=cli_env(), capture_output=True, text=True,
                          check=False)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        sys.exit(f"failed ({done.returncode}): {' '.join(map(str, cmd))}\n"
                 f"{done.stderr[-2000:]}")
    return wall, children_cpu() - c0
