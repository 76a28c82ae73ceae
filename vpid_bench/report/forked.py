"""Independent pieces of a report computed side by side: :func:`run_forked` runs calls in up
to ``workers`` forked processes. The calls are inherited through ``fork`` (never pickled: a
figure's data or a closure need not be picklable); only their results travel back. Where
``fork`` or a second core is missing, or a process dies (a crash in a library), the calls run
here, one after another: the same results, only slower.

Why: an archive report's statistical tests and its figures are each a pile of independent
pieces (two test families, 69 figures over archive/vpid1), half of the report's time; on two
cores they take half as long.
"""

from __future__ import annotations

import logging
import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

from ..machine import available_cores

log = logging.getLogger(__name__)
T = TypeVar("T")
#: The most processes one :func:`run_forked` starts (one per core, up to this).
MAX_WORKERS = 2
#: The calls of the :func:`run_forked` running now, which its forked processes inherit.
_CALLS: list[Callable[[], Any]] = []


def _call(index: int) -> Any:
    return _CALLS[index]()


def run_forked(calls: Sequence[Callable[[], T]], done: Callable[[int], Any] | None = None
               ) -> list[T]:
    """``[call() for call in calls]``, computed in forked processes where that helps
    (``done(n)`` after each of the first ``n`` results, in order). An exception a call raises
    is raised here, as it would be in this process."""
    workers = min(MAX_WORKERS, available_cores(), len(calls))
    if workers > 1 and "fork" in multiprocessing.get_all_start_methods() and not _CALLS:
        _CALLS[:] = calls
        out: list[T] = []
        try:
            with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")
                                     ) as pool:
                for result in pool.map(_call, range(len(calls))):
                    out.append(result)
                    if done is not None:
                        done(len(out))
            return out
        except BrokenProcessPool:
            log.debug("a forked process died; computing here", exc_info=True)
        finally:
            _CALLS.clear()
    out = []
    for call in calls:
        out.append(call())
        if done is not None:
            done(len(out))
    return out
