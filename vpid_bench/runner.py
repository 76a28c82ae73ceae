"""The one run loop. It owns the budget, the best-so-far and the trace.

An optimizer only proposes candidates; this loop decides what gets evaluated and what gets
recorded. It

* checks every proposal (2-D, ``dim`` columns, at least one row, finite, inside the box),
* evaluates at most ``budget`` candidates in total: a proposal larger than what is left is
  cut, its first rows evaluated and the run ended (the optimizer gets no ``tell`` for it),
* maps NaN objective values to ``inf``,
* for an optimizer that ``wants_residuals``: refuses a problem without residuals before any
  evaluation, evaluates each batch with ``problem.evaluate_with_residuals`` and tells
  ``tell(X, f, residuals=R)`` (each row still one evaluation),
* keeps its own best vector and value and a trace of (evaluations used, best so far) after
  every batch; an optimizer's own claim about its best is never used,
* times the run with a monotonic clock,
* calls ``optimizer.close()`` when the run is over, however it ended (a loop-owning
  optimizer's worker thread is stopped there).

:func:`run_many` runs several runs *in lockstep*: every step it asks each unfinished run for
its batch, evaluates all the batches in one call (:meth:`Problem.evaluate_instances`, each row
against its own run's instance) and hands every run its rows back. Each run keeps its own
optimizer (so its own generator), budget, best and trace, and goes through exactly the steps
:func:`run` takes, so its result is bit-identical to running it alone when the problem's
values do not depend on which other rows share a call (:attr:`Problem.rows_independent`).
Small populations then fill the problem's batch (30 runs of 20 candidates: 600 rows per
call), which a threaded kernel needs to use several cores.
"""

from __future__ import annotations

import contextlib
import dataclasses
import signal
import threading
import time
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from .api import Optimizer, OptimizerContractError, Problem, check_compatible


@dataclasses.dataclass
class RunResult:
    """What one run produced. ``x_best`` is in physical units; ``trace_*`` are aligned."""

    x_best: np.ndarray
    f_best: float
    evaluations: int
    budget: int
    batches: int
    trace_evaluations: list[int]
    trace_best: list[float]
    wall_time_s: float
    stopped_by: str  # "budget" or "optimizer"


def _check_proposal(X: object, optimizer: Optimizer, dim: int) -> np.ndarray:
    name = getattr(optimizer, "name", type(optimizer).__name__)
    if not isinstance(X, np.ndarray):
        raise OptimizerContractError(
            f"optimizer {name!r}: ask() returned {type(X).__name__}, expected a numpy array "
            f"of shape (n, {dim})"
        )
    if X.ndim != 2 or X.shape[1] != dim or X.shape[0] < 1:
        raise OptimizerContractError(
            f"optimizer {name!r}: ask() returned shape {X.shape}, expected (n, {dim}) with n >= 1"
        )
    X = X.astype(float, copy=True)
    if not np.all(np.isfinite(X)):
        raise OptimizerContractError(f"optimizer {name!r}: ask() returned NaN or inf candidates")
    inside = optimizer.bounds.contains(X)
    if not np.all(inside):
        row = int(np.flatnonzero(~inside)[0])
        raise OptimizerContractError(
            f"optimizer {name!r}: ask() returned candidate {row} outside the bounds: {X[row]}"
        )
    return X


def _evaluate(problem: Problem, X: np.ndarray, residuals: bool) -> tuple[np.ndarray, Any]:
    """f (NaN mapped to inf) and, when asked, the residuals of the rows of ``X``."""
    n = X.shape[0]
    if residuals:
        f, R = problem.evaluate_with_residuals(X)
        R = np.asarray(R, dtype=float)
        if R.ndim != 2 or R.shape[0] != n:
            raise ValueError(
                f"problem {problem.name!r}: evaluate_with_residuals() returned residuals of "
                f"shape {R.shape}, expected ({n}, m)"
            )
    else:
        f, R = problem.evaluate(X), None
    f = np.asarray(f, dtype=float).reshape(-1)
    if f.shape != (n,):
        raise ValueError(
            f"problem {problem.name!r}: evaluate() returned {f.shape}, expected ({n},)"
        )
    return np.where(np.isnan(f), np.inf, f), R


def run(problem: Problem, optimizer: Optimizer, budget: int, max_batches: int = 10**7) -> RunResult:
    """Run ``optimizer`` on ``problem`` until ``budget`` evaluations are used or it is done.

    ``max_batches`` guards against an optimizer that is never done and asks for nothing new;
    the budget normally ends the run long before. Raises :class:`~vpid_bench.api.ConfigError`
    before any evaluation when the optimizer wants residuals the problem does not have.
    """
    if budget < 1:
        raise ValueError(f"budget must be at least 1, got {budget}")
    try:
        return _run(problem, optimizer, budget, max_batches)
    finally:
        close = getattr(optimizer, "close", None)
        if close is not None:
            close()


def _run(problem: Problem, optimizer: Optimizer, budget: int, max_batches: int) -> RunResult:
    wants_residuals = bool(getattr(optimizer, "wants_residuals", False))
    if wants_residuals:
        check_compatible(problem, optimizer)
        optimizer.residual_groups = np.asarray(problem.residual_groups(), dtype=int).reshape(-1)
    dim = problem.bounds.dim
    used = 0
    batches = 0
    best_f = np.inf
    best_x = np.full(dim, np.nan)
    trace_n: list[int] = []
    trace_f: list[float] = []
    stopped_by = "budget"
    start = time.perf_counter()
    while used < budget:
        if optimizer.done:
            stopped_by = "optimizer"
            break
        if batches >= max_batches:
            stopped_by = "max_batches"
            break
        X = _check_proposal(optimizer.ask(), optimizer, dim)
        left = budget - used
        cut = X.shape[0] > left
        if cut:
            X = X[:left]
        f, R = _evaluate(problem, X, wants_residuals)
        if R is not None and R.shape[1] != optimizer.residual_groups.size:
            raise ValueError(
                f"problem {problem.name!r}: {R.shape[1]} residuals per row but "
                f"residual_groups() has {optimizer.residual_groups.size} entries"
            )
        used += X.shape[0]
        batches += 1
        i = int(np.argmin(f))
        if f[i] < best_f or batches == 1:  # the first batch always sets a best vector
            best_f = float(f[i])
            best_x = X[i].copy()
        trace_n.append(used)
        trace_f.append(best_f)
        if cut:
            break
        if R is None:
            optimizer.tell(X, f.copy())
        else:
            optimizer.tell(X, f.copy(), residuals=R)
    return RunResult(
        x_best=best_x,
        f_best=best_f,
        evaluations=used,
        budget=budget,
        batches=batches,
        trace_evaluations=trace_n,
        trace_best=trace_f,
        wall_time_s=time.perf_counter() - start,
        stopped_by=stopped_by,
    )


class RunTimeoutError(Exception):
    """A run went past its wall-time limit (the job's ``run_timeout_s``)."""


@dataclasses.dataclass
class Lane:
    """One run of a lockstep group (:func:`run_many`).

    ``problem`` is the instance the run fits (checks and error messages use it), ``instance``
    its index for the group problem's :meth:`~vpid_bench.api.Problem.evaluate_instances`.
    """

    problem: Problem
    optimizer: Optimizer
    budget: int
    instance: int = 0


@dataclasses.dataclass
class _LaneState:
    """The bookkeeping :func:`_run` keeps in local variables, for one lane of a group."""

    lane: Lane
    dim: int
    used: int = 0
    batches: int = 0
    best_f: float = np.inf
    best_x: np.ndarray | None = None
    trace_n: list[int] = dataclasses.field(default_factory=list)
    trace_f: list[float] = dataclasses.field(default_factory=list)
    stopped_by: str = "budget"
    seconds: float = 0.0  # this run's own time: its ask/tell and its share of evaluations
    outcome: RunResult | BaseException | None = None
    X: np.ndarray | None = None  # the batch asked this step (already cut to the budget)
    cut: bool = False

    def finish(self) -> None:
        self.outcome = RunResult(
            x_best=self.best_x if self.best_x is not None else np.full(self.dim, np.nan),
            f_best=self.best_f, evaluations=self.used, budget=self.lane.budget,
            batches=self.batches, trace_evaluations=self.trace_n, trace_best=self.trace_f,
            wall_time_s=self.seconds, stopped_by=self.stopped_by,
        )


class _Alarm:
    """A hard wall-time limit on one call: ``with alarm.limit(seconds):`` raises
    :class:`RunTimeoutError` inside the call once ``seconds`` have passed (SIGALRM: POSIX main
    thread only; elsewhere only the soft check between steps of :func:`run_many` applies)."""

    def __init__(self, limit: float | None) -> None:
        self.limit_s = limit
        self.enabled = (limit is not None and hasattr(signal, "setitimer")
                        and threading.current_thread() is threading.main_thread())
        self._previous: Any = None

    def __enter__(self) -> _Alarm:
        if self.enabled:
            self._previous = signal.signal(signal.SIGALRM, self._expired)
        return self

    def __exit__(self, *exc: object) -> None:
        if self.enabled:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self._previous)

    def _expired(self, signum: int, frame: Any) -> None:
        raise _timeout_error(self.limit_s or 0.0)

    @contextlib.contextmanager
    def limit(self, seconds: float | None) -> Iterator[None]:
        if not self.enabled or seconds is None:
            yield
            return
        signal.setitimer(signal.ITIMER_REAL, max(seconds, 1e-6))
        try:
            yield
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)


def _timeout_error(limit: float) -> RunTimeoutError:
    return RunTimeoutError(f"the run took longer than run_timeout_s={limit:g} s")


def run_many(problem: Problem, lanes: Sequence[Lane], timeout_s: float | None = None,
             max_batches: int = 10**7) -> list[RunResult | BaseException]:
    """Run every lane in lockstep (see module); one outcome per lane, in order: its
    :class:`RunResult`, or the exception that ended it.

    ``problem`` evaluates the gathered rows (``problem.evaluate_instances(X, instance)``).
    A lane that raises (in its optimizer, a proposal check or its rows' evaluation) fails
    alone: a gathered evaluation that raises is repeated lane by lane with each lane's own
    ``problem.evaluate`` to find the culprit. ``timeout_s`` limits each run's own time (its
    ``ask``/``tell`` plus its share of the gathered evaluations, in proportion to its rows);
    a run past it ends with :class:`RunTimeoutError`. Lanes must not want residuals (they
    run alone, with :func:`run`). ``KeyboardInterrupt`` stops the whole group (every
    optimizer is closed first).
    """
    states = [_LaneState(lane, problem.bounds.dim) for lane in lanes]
    for st in states:
        if st.lane.budget < 1:
            st.outcome = ValueError(f"budget must be at least 1, got {st.lane.budget}")
        elif getattr(st.lane.optimizer, "wants_residuals", False):
            st.outcome = ValueError("an optimizer that wants residuals cannot run in lockstep")
    try:
        with _Alarm(timeout_s) as alarm:
            while True:
                active = [st for st in states if st.outcome is None]
                if not active:
                    break
                asked = [st for st in active if _ask(st, alarm, timeout_s, max_batches)]
                if asked:
                    _evaluate_and_tell(problem, asked, alarm, timeout_s)
    finally:
        for st in states:
            close = getattr(st.lane.optimizer, "close", None)
            if close is not None:
                try:
                    close()
                except Exception as exc:  # noqa: BLE001 - a failing close fails its run only
                    if not isinstance(st.outcome, BaseException):
                        st.outcome = exc
    return [st.outcome for st in states]


def _remaining(st: _LaneState, timeout_s: float | None) -> float | None:
    return None if timeout_s is None else timeout_s - st.seconds


def _guarded(st: _LaneState, alarm: _Alarm, timeout_s: float | None, fn: Any) -> bool:
    """Call ``fn()`` as lane ``st`` (its time counted, its limit applied); an exception ends
    the lane (its outcome) and returns False."""
    t0 = time.perf_counter()
    try:
        with alarm.limit(_remaining(st, timeout_s)):
            fn()
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - crash isolation: this lane only
        st.outcome = exc
        return False
    finally:
        st.seconds += time.perf_counter() - t0
    if timeout_s is not None and st.seconds > timeout_s:
        st.outcome = _timeout_error(timeout_s)
        return False
    return True


def _ask(st: _LaneState, alarm: _Alarm, timeout_s: float | None, max_batches: int) -> bool:
    """The top of :func:`_run`'s loop for one lane: stop, or ask and check its next batch."""
    if st.used >= st.lane.budget:
        st.finish()
        return False
    opt = st.lane.optimizer

    def ask() -> None:
        if opt.done:
            st.stopped_by = "optimizer"
            return
        if st.batches >= max_batches:
            st.stopped_by = "max_batches"
            return
        X = _check_proposal(opt.ask(), opt, st.dim)
        left = st.lane.budget - st.used
        st.cut = X.shape[0] > left
        st.X = X[:left] if st.cut else X

    st.X = None
    if not _guarded(st, alarm, timeout_s, ask):
        return False
    if st.X is None:
        st.finish()
        return False
    return True


def _evaluate_and_tell(problem: Problem, asked: list[_LaneState], alarm: _Alarm,
                       timeout_s: float | None) -> None:
    """Evaluate the asked batches in one call, then do each lane's bookkeeping and ``tell``."""
    X = np.concatenate([st.X for st in asked]) if len(asked) > 1 else asked[0].X
    sizes = [st.X.shape[0] for st in asked]
    index = np.repeat(np.array([st.lane.instance for st in asked], dtype=np.int64), sizes)
    budget = None if timeout_s is None else sum(_remaining(st, timeout_s) for st in asked)
    t0 = time.perf_counter()
    try:
        with alarm.limit(budget):
            f_all = _values(problem, problem.evaluate_instances(X, index), X.shape[0])
    except KeyboardInterrupt:
        raise
    except BaseException:  # noqa: BLE001 - find the lane whose rows raise, fail it alone
        f_all = None
    share = (time.perf_counter() - t0) / X.shape[0]
    start = 0
    for st, n in zip(asked, sizes):
        rows = slice(start, start + n)
        start += n
        if f_all is not None:
            st.seconds += share * n
            f = f_all[rows]
        else:
            alone: dict[str, np.ndarray] = {}

            def evaluate_alone(st: _LaneState = st, alone: dict = alone) -> None:
                inst = st.lane.problem
                alone["f"] = _values(inst, inst.evaluate(st.X), st.X.shape[0])

            if not _guarded(st, alarm, timeout_s, evaluate_alone):
                continue
            f = alone["f"]
        _book(st, f)
        if timeout_s is not None and st.seconds > timeout_s:
            st.outcome = _timeout_error(timeout_s)
            continue
        if st.cut:
            st.finish()
            continue
        Xs = st.X
        _guarded(st, alarm, timeout_s, lambda st=st, Xs=Xs, f=f: st.lane.optimizer.tell(Xs,
                                                                                     f.copy()))


def _values(problem: Problem, f: Any, n: int) -> np.ndarray:
    """``f`` as :func:`_evaluate` returns it (shape checked, NaN mapped to inf)."""
    f = np.asarray(f, dtype=float).reshape(-1)
    if f.shape != (n,):
        raise ValueError(
            f"problem {problem.name!r}: evaluate() returned {f.shape}, expected ({n},)"
        )
    return np.where(np.isnan(f), np.inf, f)


def _book(st: _LaneState, f: np.ndarray) -> None:
    """The bookkeeping of :func:`_run` after an evaluation: budget, best, trace."""
    st.used += st.X.shape[0]
    st.batches += 1
    i = int(np.argmin(f))
    if f[i] < st.best_f or st.batches == 1:
        st.best_f = float(f[i])
        st.best_x = st.X[i].copy()
    st.trace_n.append(st.used)
    st.trace_f.append(st.best_f)
