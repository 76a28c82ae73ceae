"""The bridge for optimizers that own their loop (``scipy.optimize.minimize`` and friends).

:class:`LoopOptimizer` runs the library's loop in a worker thread and hands each batch across
to the run loop's ask and tell, strictly in turn (the run stays deterministic); ``close``
unwinds the library's frames with an internal ``BaseException`` and joins the thread
(docs/peers.md, the bridge). The pattern is nevergrad's "recast" optimizers'; this is an
independent implementation with two ``queue.SimpleQueue``.
"""

from __future__ import annotations

import abc
import queue
import threading
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from .bounds import Bounds
from .optimizer import Optimizer, OptimizerParams

#: How long ``close`` waits for the library's loop to unwind (s); it normally takes microseconds.
JOIN_TIMEOUT_S = 10.0


class _Stop(BaseException):
    """Unwinds the library's loop once the run is over (past any ``except Exception`` of it)."""


_STOP = object()


class LoopOptimizer(Optimizer):
    """An optimizer written as one call, ``minimize(evaluate)``, that owns its loop.

    ``evaluate(X)`` takes an ``(n, dim)`` batch inside the bounds and returns ``f`` ``(n,)``,
    or ``(f, R)`` with residuals ``(n, m)`` when ``wants_residuals``; it may never return
    (the budget is the run loop's). When ``minimize`` returns, ``done`` is true and its value
    is in ``result``. Randomness from ``self.rng`` (used only while the run loop waits).
    """

    def __init__(self, params: OptimizerParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        self._to_worker: queue.SimpleQueue = queue.SimpleQueue()
        self._from_worker: queue.SimpleQueue = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._pending: np.ndarray | None = None
        self._finished = False
        self._stopping = False
        self._closed = False
        self._done_set = False
        self.result: Any = None

    @abc.abstractmethod
    def minimize(self, evaluate: Callable[[np.ndarray], Any]) -> Any:
        """Run the library's loop, calling ``evaluate`` on batches of rows; may return
        anything (kept in ``result``) or never return (the budget ends it)."""

    # -- the worker thread --------------------------------------------------------------------
    def _evaluate(self, X: np.ndarray) -> Any:
        if self._stopping:
            raise _Stop
        X = np.array(X, dtype=float, copy=True)
        if X.ndim != 2 or X.shape[1] != self.bounds.dim:
            raise ValueError(f"evaluate() takes an (n, {self.bounds.dim}) batch of rows, got "
                             f"shape {X.shape}")
        if X.shape[0] == 0:
            f0 = np.empty(0)
            return (f0, np.empty((0, 0))) if self.wants_residuals else f0
        self._from_worker.put(("ask", X))
        message = self._to_worker.get()
        if message is _STOP:
            raise _Stop
        f, R = message
        return (f, R) if self.wants_residuals else f

    def _work(self) -> None:
        try:
            result = self.minimize(self._evaluate)
        except _Stop:
            return
        except BaseException as exc:  # handed to the run loop's thread, raised there
            self._from_worker.put(("error", exc))
            return
        self._from_worker.put(("finished", result))

    # -- the run loop's side ------------------------------------------------------------------
    def _receive(self) -> None:
        kind, payload = self._from_worker.get()
        if kind == "ask":
            self._pending = payload
            return
        self._pending = None
        self._finished = True
        if self._thread is not None:
            self._thread.join(JOIN_TIMEOUT_S)
        if kind == "error":
            raise payload
        self.result = payload

    def _start(self) -> None:
        if self._thread is not None or self._closed:
            return
        self._thread = threading.Thread(target=self._work, name=f"vpid-bench loop of "
                                        f"{self.name}", daemon=True)
        self._thread.start()
        self._receive()

    def ask(self) -> np.ndarray:
        self._start()
        if self._pending is None:
            raise RuntimeError(f"optimizer {self.name!r}: nothing to ask, its loop has "
                               + ("been closed" if self._closed else "returned"))
        return self._pending.copy()

    def tell(self, X: np.ndarray, f: np.ndarray, residuals: np.ndarray | None = None) -> None:
        if self._pending is None or np.shape(X) != self._pending.shape:
            raise ValueError("tell() must follow ask() with the whole batch it returned")
        if self.wants_residuals and residuals is None:
            raise ValueError(f"optimizer {self.name!r} wants residuals: tell(X, f, residuals=R)")
        f = np.array(f, dtype=float, copy=True).reshape(-1)
        R = None if residuals is None else np.array(residuals, dtype=float, copy=True)
        self._pending = None
        self._to_worker.put((f, R))
        self._receive()

    @property
    def done(self) -> bool:
        """True once ``minimize`` has returned (or ``done`` was set); reading it starts the
        loop, so one that returns at once is seen before the first ask."""
        if not (self._done_set or self._closed):
            self._start()
        return self._finished or self._done_set or self._closed

    @done.setter
    def done(self, value: bool) -> None:
        self._done_set = bool(value)

    def close(self) -> None:
        """Stop the library's loop if it is still waiting for values and join its thread."""
        if self._closed:
            return
        self._closed = True
        self._pending = None
        thread = self._thread
        if thread is not None and thread.is_alive():
            self._stopping = True
            self._to_worker.put(_STOP)
            thread.join(JOIN_TIMEOUT_S)
            if thread.is_alive():  # pragma: no cover - a library that ignores the stop
                warnings.warn(f"optimizer {self.name!r}: its loop did not stop within "
                              f"{JOIN_TIMEOUT_S} s", RuntimeWarning, stacklevel=2)

    def __enter__(self) -> LoopOptimizer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
