"""Drawing the report's figures in worker processes while the report computes the rest.

A figure costs a few hundred milliseconds of matplotlib (layout, text, rasterising, PNG),
and importing matplotlib costs about half a second: drawn one after another they were most
of a report's time. :class:`FigureDrawer` starts its workers when the report starts, so they
import matplotlib while the report's process reads the records and runs the tests; each
figure is then handed over as a module-level function and plain data (numpy arrays, lists,
dicts, never the records) and drawn in a worker. The report collects the results at the end.

* Workers are *spawned* (a fresh interpreter), never forked: the report also runs inside
  the ``vpid-bench`` process after a sweep, whose numba and BLAS threads a fork would copy
  in an undefined state.
* A figure whose function raises costs that figure only: its result is the text
  ``"failed: <error>"`` and the report says why it is missing.
* No worker outlives the drawer: leaving the ``with`` block waits for the figures, and an
  exception (a KeyboardInterrupt too) cancels what is queued and terminates the workers.
* ``mode="serial"`` draws in the calling process, one figure at a time (and ``"auto"`` does
  so when only one core is available): the same files, without workers.
* A spawned worker imports the calling program's main module (as ``__mp_main__``), so a
  script of the user's that builds a report from its top level, unguarded by
  ``if __name__ == "__main__":``, would run again in every worker. ``"auto"`` therefore
  uses workers only when that import is known to be harmless (:func:`main_is_safe`): the
  ``vpid-bench`` and ``vpid-bench-report`` commands, ``python -c``, ``python -m``, an
  interactive session or a notebook. A script of one's own asks for them with
  ``figures="parallel"`` under such a guard.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

from ..machine import available_cores

log = logging.getLogger(__name__)

FigureMode = Literal["auto", "parallel", "serial"]
#: The modes :class:`FigureDrawer` accepts (``--figures`` of ``vpid-bench-report``).
MODES: tuple[str, ...] = ("auto", "parallel", "serial")
#: At most this many worker processes draw the figures.
MAX_WORKERS = 4


def default_workers(cores: int | None = None) -> int:
    """How many workers draw the figures by default: one per core, at most
    :data:`MAX_WORKERS`, and 0 (draw serially) on a single core."""
    cores = available_cores() if cores is None else cores
    return 0 if cores <= 1 else min(cores, MAX_WORKERS)


#: The console scripts of this project: their main module calls ``main()`` only under
#: ``if __name__ == "__main__":``, so a worker may import it.
SAFE_SCRIPTS = ("vpid-bench", "vpid-bench-report")


def main_is_safe() -> bool:
    """Whether a spawned worker may import this program's main module without running it
    again: no file (interactive, ``python -c``, a notebook), a module run with ``python -m``
    (imported by name; such modules guard their entry point), or one of
    :data:`SAFE_SCRIPTS`."""
    import sys

    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None or getattr(main, "__spec__", None) is not None:
        return True
    return Path(path).name in SAFE_SCRIPTS


def _warm_up() -> None:
    """Worker initializer: import matplotlib with the Agg backend before any figure comes."""
    from .figures import _plt

    _plt()


def _ready() -> None:
    """A no-op task: submitting it makes the pool start its workers now."""


def call(func: Callable[..., Any], args: tuple[Any, ...], kwargs: dict[str, Any]) -> Any:
    """Run one figure function (in a worker or in the calling process)."""
    return func(*args, **kwargs)


def save_drawn(func: Callable[..., Any], path: Path, args: tuple[Any, ...],
               kwargs: dict[str, Any]) -> Path:
    """Call ``func(*args, **kwargs)``, which returns a matplotlib figure, and save that
    figure as the PNG ``path`` (a plugin's :meth:`.sections.ReportContext.draw_figure`)."""
    from .figures import save

    return save(func(*args, **kwargs), path)


def failure(exc: BaseException) -> str:
    """The text a figure that raised leaves in the report."""
    return f"failed: {type(exc).__name__}: {exc}"


class FigureDrawer:
    """Draw figures in worker processes (or serially); see the module docstring.

    ``mode``: ``"parallel"``, ``"serial"`` or ``"auto"`` (parallel when more than one core
    is available). ``workers``: the number of worker processes (default
    :func:`default_workers`). Use as a context manager; :meth:`submit` each figure under a
    key, :meth:`results` gives every key's PNG path or why it was not drawn.
    """

    def __init__(self, mode: FigureMode = "auto", workers: int | None = None) -> None:
        if mode not in MODES:
            raise ValueError(f"figures must be one of {', '.join(MODES)}, not {mode!r}")
        n = default_workers() if workers is None else int(workers)
        if mode == "parallel":
            n = max(n, 1)
        elif mode == "auto" and n >= 1 and not main_is_safe():
            log.info("figures drawn serially: this script's main module would run again in "
                     "each worker (figures='parallel' under an `if __name__ == \"__main__\":` "
                     "guard draws them in workers)")
            n = 0
        self.mode = "parallel" if mode != "serial" and n >= 1 else "serial"
        self.workers = n if self.mode == "parallel" else 0
        self._pool: Any = None
        self._pending: dict[Any, Any] = {}
        self._done: dict[Any, Any] = {}
        if self.mode == "parallel":
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            try:
                self._pool = ProcessPoolExecutor(
                    max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
                    initializer=_warm_up)
                self._pool.submit(_ready)  # start the workers now: they import matplotlib
            except (OSError, ImportError, NotImplementedError) as exc:  # no semaphores, ...
                log.warning("figure workers could not start (%s); drawing serially", exc)
                self.terminate()
                self.mode, self.workers = "serial", 0

    def __enter__(self) -> FigureDrawer:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.close()
        else:
            self.terminate()

    def submit(self, key: Any, func: Callable[..., Any], *args: Any, **kwargs: Any) -> None:
        """Draw ``func(*args, **kwargs)`` (a module-level function that writes a PNG and
        returns its path, or returns why not) under ``key``. In parallel mode its arguments
        are pickled to a worker: pass plain data."""
        if self._pool is None:
            try:
                self._done[key] = call(func, args, kwargs)
            except Exception as exc:  # a figure's fault costs that figure only
                log.debug("figure %r failed", key, exc_info=True)
                self._done[key] = failure(exc)
            return
        self._pending[key] = (self._pool.submit(call, func, args, kwargs), func, args, kwargs)

    def results(self) -> dict[Any, Any]:
        """Every submitted key's result (waits for the workers), in submission order. A
        figure whose worker died (the pool broke: killed, out of memory) is drawn again
        here, serially; one whose function raised is not."""
        from concurrent.futures.process import BrokenProcessPool

        for key, (fut, func, args, kwargs) in list(self._pending.items()):
            try:
                self._done[key] = fut.result()
            except BrokenProcessPool:
                log.warning("a figure worker died; drawing %r here", key)
                try:
                    self._done[key] = call(func, args, kwargs)
                except Exception as exc:
                    self._done[key] = failure(exc)
            except Exception as exc:  # raised in the worker
                log.debug("figure %r failed", key, exc_info=True)
                self._done[key] = failure(exc)
            del self._pending[key]
        return dict(self._done)

    def close(self) -> None:
        """Wait for the figures and stop the workers."""
        if self._pool is not None:
            self.results()
            self._pool.shutdown(wait=True)
            self._pool = None

    def terminate(self) -> None:
        """Cancel what is queued and kill the workers now (after an error or an interrupt)."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for p in processes:
            if p.is_alive():
                p.terminate()
        for p in processes:
            p.join(timeout=10)
        self._pending.clear()
