"""A problem and an optimizer that commit one fault at one place, for the fault matrix
(``test_fault_matrix.py``). Module level, so worker processes can import them by name.

Faults: ``raise`` (RuntimeError), ``systemexit``, ``exit`` (``os._exit(3)``), ``abort``
(``os.abort()``), ``sleep`` (30 s, past any test's ``run_timeout_s``), ``thread`` (a non-daemon
thread sleeping an hour), ``chdir`` (into a fresh temporary folder), ``spam`` (1 MB to stdout and
stderr); and processes (issue 35): ``linger`` (a forked child left sleeping 40 s with everything
it inherited), ``forkboth`` (a fork whose copies both go on), ``orphan`` (a daemon, in a session
of its own, holding the standard streams 40 s), ``closepipe`` (every descriptor above 2 closed,
the worker's pipe among them). A process fault is committed once per process; each process it
starts notes its id (process_plugins.note).

Places: the optimizer's ``constructor``, ``ask``, ``tell``, ``done``, ``close``; the problem's
``build`` (its constructor), ``evaluate``, ``residuals`` (fitted by an optimizer that asks for
them), ``metrics``, ``describe``, ``polish`` (its residual groups, asked by the optimum polish
after the runs: the truth is known only in these cells, so the analysis runs there alone) and
``signals`` (the best run's, after the runs)."""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile
import threading
import time

import numpy as np
from process_plugins import daemon, fork_noted, linger, once

from vpid_bench.api import Bounds, Optimizer, OptimizerParams, Problem, ProblemConfig

FAULTS = ("raise", "systemexit", "exit", "abort", "sleep", "thread", "chdir", "spam",
          "linger", "forkboth", "orphan", "closepipe")
OPTIMIZER_PLACES = ("constructor", "ask", "tell", "done", "close")
PROBLEM_PLACES = ("build", "evaluate", "residuals", "metrics", "describe", "polish", "signals")
#: Faults that end or stop a run (the others leave it ok).
FATAL = ("raise", "systemexit", "exit", "abort", "sleep", "closepipe")
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
    if fault == "linger" and once(fault):
        fork_noted(fault, linger)
    if fault == "forkboth" and once(fault):
        fork_noted(fault)
    if fault == "orphan" and once(fault):
        daemon(fault)
    if fault == "closepipe":
        os.closerange(3, 65536)


class FaultyProblem(Problem):
    """sum((x - 2)^2) over [-1, 1]^3, residuals x - 2 (an optimum of 3, at the corner (1, 1,
    1): not 0, which the report cannot yet divide by); commits ``fault`` at ``place`` when it
    is its own. Signals only in the cells of that place (each drawn by the report)."""

    @dataclasses.dataclass(frozen=True)
    class Config(ProblemConfig):
        fault: str = "none"
        place: str = "none"

    rows_independent = True

    def __init__(self, config) -> None:
        super().__init__(config)
        self._maybe("build")

    @property
    def bounds(self) -> Bounds:
        return BOX

    @property
    def x_true(self) -> np.ndarray | None:
        return np.full(3, 0.5) if self.config.place == "polish" else None

    def _maybe(self, place: str) -> None:
        if self.config.place == place:
            commit(self.config.fault)

    def residual_groups(self) -> np.ndarray:
        self._maybe("polish")
        return np.zeros(3, dtype=int)

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        self._maybe("metrics")
        return {"norm": float(np.linalg.norm(x))}

    def describe(self) -> dict[str, object]:
        self._maybe("describe")
        return {}

    def signals(self, x: np.ndarray) -> dict[str, np.ndarray] | None:
        if self.config.place != "signals":
            return None
        self._maybe("signals")
        t = np.linspace(0.0, 1.0, 5)
        return {"t": t, "y:measured": t, "y:fitted": t * float(np.sum(x))}

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        self._maybe("evaluate")
        return np.sum((np.asarray(X) - 2.0) ** 2, axis=1)

    def residuals(self, X: np.ndarray) -> np.ndarray:
        self._maybe("residuals")
        return np.asarray(X, dtype=float) - 2.0


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
