"""What the benchmark scripts share: the two commands in a child process, a job's config
composed as the command composes it, and the timers. Imported as ``_shared`` (a script run as
``python benchmarks/<script>.py`` has this folder first on ``sys.path``)."""

from __future__ import annotations

import contextlib
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from hydra import compose as hydra_compose
from hydra import initialize_config_module
from hydra.core.global_hydra import GlobalHydra

from vpid_bench.build import build_problem
from vpid_bench.plugins import Registry
from vpid_bench.shell.config_store import register_configs

#: ``vpid-bench`` and ``vpid-bench-report`` in a child process of this interpreter (the
#: virtual environment's, whatever is first on PATH).
CLI = [sys.executable, "-c", "from vpid_bench.shell.main import main; main()"]
REPORT = [sys.executable, "-c", "from vpid_bench.report.cli import main; main()"]


def cli_env() -> dict[str, str]:
    """A child command's environment: headless matplotlib, its own config folder (unless set)."""
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    env.setdefault("MPLCONFIGDIR", tempfile.mkdtemp(prefix="vpid-mpl-"))
    return env


def registry_with_configs() -> Any:
    """The installed plugins' registry, their config nodes stored in Hydra's ConfigStore
    (once per process, before :func:`compose`)."""
    registry = Registry()
    register_configs(registry)
    return registry


def compose(overrides: list[str]) -> Any:
    """The job config the command would compose for ``overrides`` (Hydra's global state
    cleared before; the config nodes stored by :func:`registry_with_configs`)."""
    GlobalHydra.instance().clear()
    with initialize_config_module(version_base="1.3", config_module="vpid_bench.conf"):
        return hydra_compose(config_name="config", overrides=list(overrides))


def run_timed(cmd: list[str], cwd: Any = None, check: bool = True) -> tuple[float, float]:
    """Wall and CPU seconds (user + system of the child: a shared machine moves them less) of
    ``cmd`` run in ``cwd``; with ``check`` it must succeed, else exit with its stderr's end."""
    def children_cpu() -> float:
        r = resource.getrusage(resource.RUSAGE_CHILDREN)
        return r.ru_utime + r.ru_stime

    c0, t0 = children_cpu(), time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, env=cli_env(), capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if check and done.returncode != 0:
        sys.exit(f"failed ({done.returncode}): {' '.join(map(str, cmd))}\n"
                 f"{done.stderr[-2000:]}")
    return wall, children_cpu() - c0


def interleaved(calls: dict[str, Callable[[], object]], rounds: int, number: int = 1,
                pick: Callable[[list[float]], float] = statistics.median,
                seconds: float | None = None) -> dict[str, float]:
    """Seconds per call of each of ``calls`` (each called once first: compilation, caches),
    timed in ``rounds`` interleaved rounds of ``number`` calls each (or as many as take about
    ``seconds``), so a change of load meets them alike; reduced over the rounds by ``pick``
    (``min``: the code's own time on a loaded machine)."""
    numbers = {}
    for name, fn in calls.items():
        t0 = time.perf_counter()
        fn()
        once = time.perf_counter() - t0
        numbers[name] = number if seconds is None else max(1, int(seconds / max(once, 1e-9)))
    times: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(rounds):
        for name, fn in calls.items():
            t0 = time.perf_counter()
            for _ in range(numbers[name]):
                fn()
            times[name].append((time.perf_counter() - t0) / numbers[name])
    return {name: pick(t) for name, t in times.items()}


def kernel_us(cfg: dict[str, Any], seconds: float = 1.0, batch: int = 20) -> tuple[float, float]:
    """The problem ``cfg``'s (``name`` and keys) µs per candidate on one thread, batches of
    ``batch`` random candidates in its box, the median of 5 timings of ``seconds / 5``; in
    wall time and in this process's CPU time (which another program does not inflate)."""
    problem = build_problem(Registry(), cfg)
    problem.set_threads(1)
    X = problem.bounds.sample(np.random.default_rng(0), batch)
    problem.evaluate(X)  # compiled on first use
    wall, cpu = [], []
    for _ in range(5):
        reps, t0, c0 = 0, time.perf_counter(), time.process_time()
        while time.perf_counter() - t0 < seconds / 5:
            problem.evaluate(X)
            reps += 1
        wall.append((time.perf_counter() - t0) / reps / batch * 1e6)
        cpu.append((time.process_time() - c0) / reps / batch * 1e6)
    return statistics.median(wall), statistics.median(cpu)


def parse_keys(text: str) -> dict[str, Any]:
    """``"a=1,b=false,c=paper"`` as ``{"a": 1, "b": False, "c": "paper"}``."""
    def scalar(value: str) -> Any:
        if value.lower() in ("true", "false"):
            return value.lower() == "true"
        for kind in (int, float):
            with contextlib.suppress(ValueError):
                return kind(value)
        return value

    pairs = (item.split("=", 1) for item in text.split(",") if item)
    return {key.strip(): scalar(value.strip()) for key, value in pairs}
