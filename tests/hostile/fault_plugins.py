"""A problem and an optimizer that commit one fault at one place, for the fault matrix
(``test_fault_matrix.py``). Module level, so worker processes can import them by name.

Faults: ``raise`` (RuntimeError), ``systemexit``, ``exit`` (``os._exit(3)``), ``abort``
(``os.abort()``), ``sleep`` (30 s, past any test's ``run_timeout_s``), ``thread`` (a non-daemon
thread sleeping an hour), ``chdir`` (into a fresh temporary folder), ``spam`` (1 MB to stdout and
stderr). Places: the optimizer's ``constructor``, ``ask``, ``tell``, ``done``, ``close``; the
problem's ``evaluate`` and ``residuals`` (the latter fitted by ``lsq``, which asks for them)."""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile
import threading
import time

import numpy as np

from vpid_bench.api import Bounds, Optimizer, OptimizerParams, Problem, ProblemConfig

FAULTS = ("raise", "systemexit", "exit", "abort", "sleep", "thread", "chdir", "spam")
OPTIMIZER_PLACES = ("constructor", "ask", "tell", "done", "close")
PROBLEM_PLACES = ("evaluate", "residuals")
#: Faults that end or stop a run (the others leave it ok).
FATAL = ("raise", "systemexit", "exit", "abort", "sleep")
BOX = Bounds(-np.ones(3), np.ones(3), ("a", "b", "c"))


def commit(fault: str) -> None:
    """Commit ``fault`` here and now."""
    if fault == "raise":
        raise RuntimeError("planted fault")
    if fault == "systemexit":
        raise SystemExit(4)
    if fault == "exit":
        os._exit(3)
    if fault == "abort":
        import resource

        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        os.abort()
    if fault == "sleep":
        time.sleep(30)
    if fault == "thread":
        threading.Thread(target=time.sleep, args=(3600,), name="planted").start()
    if fault == "chdir":
        os.chdir(tempfile.mkdtemp(prefix="planted-"))
    if fault == "spam":
        sys.stdout.write("x" * 2**20 + "\n")
        sys.stderr.write("y" * 2**20 + "\n")


class FaultyProblem(Problem):
    """sum(x^2) over [-1, 1]^3, residuals x; commits ``fault`` at ``place`` when it is its own."""

    @dataclasses.dataclass(frozen=True)
    class Config(ProblemConfig):
        fault: str = "none"
        place: str = "none"

    rows_independent = True

    @property
    def bounds(self) -> Bounds:
        return BOX

    def _maybe(self, place: str) -> None:
        if self.config.place == place:
            commit(self.config.fault)

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        self._maybe("evaluate")
        return np.sum(np.asarray(X) ** 2, axis=1)

    def residuals(self, X: np.ndarray) -> np.ndarray:
        self._maybe("residuals")
        return np.asarray(X, dtype=float)


class FaultyOptimizer(Optimizer):
    """Random batches of ``ps``; commits ``fault`` at ``place`` when it is its own."""

    @dataclasses.dataclass(frozen=True)
    class Params(OptimizerParams):
        fault: str = "none"
        place: str = "none"

    def __init__(self, params, bounds, rng) -> None:
        super().__init__(params, bounds, rng)
        self._maybe("constructor")

    def _maybe(self, place: str) -> None:
        if self.params.place == place:
            commit(self.params.fault)

    def ask(self) -> np.ndarray:
        self._maybe("ask")
        return self.bounds.sample(self.rng, self.params.ps)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        self._maybe("tell")

    @property
    def done(self) -> bool:
        self._maybe("done")
        return False

    @done.setter
    def done(self, value: bool) -> None:
        pass

    def close(self) -> None:
        self._maybe("close")


class FaultyResidualOptimizer(FaultyOptimizer):
    """The same, asking for residuals (so the problem's ``residuals`` is called)."""

    wants_residuals = True

    def tell(self, X: np.ndarray, f: np.ndarray, residuals: np.ndarray | None = None) -> None:
        self._maybe("tell")
