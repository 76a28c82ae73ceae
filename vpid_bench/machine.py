"""What this process may use of the machine."""

from __future__ import annotations

import contextlib
import functools
import os
import platform
from collections.abc import Iterator
from typing import Any

from threadpoolctl import threadpool_info, threadpool_limits


def available_cores() -> int:
    """The cores this process may run on: its CPU affinity where the OS says (Linux), else
    every core; at least 1. The default of the ``threads`` and ``workers`` keys."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def environ(name: str, value: str) -> Iterator[None]:
    """Inside: the environment variable ``name`` is ``value``; the one before restored after."""
    saved = os.environ.get(name)
    os.environ[name] = value
    try:
        yield
    finally:
        if saved is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = saved


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """numpy's and scipy's BLAS/OpenMP pools limited to one thread for the job, unless the
    user set a thread count in the environment: a problem's own threads (``threads``) and the
    launcher's workers share the cores, and oversubscribed BLAS threads slow them all down."""
    if any(os.environ.get(v) for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                       "MKL_NUM_THREADS", "VPID_BENCH_BLAS_THREADS")):
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield


@functools.lru_cache(maxsize=1)
def machine_facts() -> dict[str, Any]:
    """What a run's timings depend on, for its record: the CPU model, the cores this process
    may use and the machine has, and each BLAS/OpenMP library numpy and scipy loaded (its
    implementation, version, architecture and threads), as threadpoolctl reports them.
    Computed once per process."""
    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError), open("/proc/cpuinfo", encoding="utf-8") as fh:
        cpu = next((ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")), cpu)
    try:
        import scipy.linalg  # noqa: F401 - load scipy's BLAS too, as a run would
        blas = [{k: lib.get(src) for k, src in (
            ("api", "internal_api"), ("version", "version"),
            ("architecture", "architecture"), ("threads", "num_threads"))}
            for lib in threadpool_info()]
    except Exception:  # noqa: BLE001 - facts for the record, never a reason to fail a run
        blas = []
    return {"cpu": cpu, "cores": os.cpu_count(), "cores_available": available_cores(), "blas": blas}
