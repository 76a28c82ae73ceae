"""What this process may use of the machine."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator


def available_cores() -> int:
    """The cores this process may run on: its CPU affinity where the OS says (Linux), else
    every core; at least 1. The default of the ``threads`` and ``workers`` keys."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """numpy's and scipy's BLAS/OpenMP pools limited to one thread for the job, unless the
    user set a thread count in the environment: a problem's own threads (``threads``) and the
    launcher's workers share the cores, and oversubscribed BLAS threads slow them all down."""
    if any(os.environ.get(v) for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                       "MKL_NUM_THREADS", "VPID_BENCH_BLAS_THREADS")):
        yield
        return
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield
