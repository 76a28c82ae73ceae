"""The one run loop. It owns the budget, the best-so-far and the trace.

An optimizer only proposes candidates; this loop checks every proposal, evaluates at most
``budget`` candidates in all (a proposal larger than what is left is cut, the run ended
without a ``tell``), keeps each run's books in one :class:`Ledger`, times each run and calls
``optimizer.close()`` however the run ended (the contract: docs/plugins.md).

:func:`run_many` runs one run or several *in lockstep* (the batches that need only values
evaluated in one :meth:`Problem.evaluate_instances` call; bit-identical to running each
alone when :attr:`Problem.rows_independent`). :func:`run` is the loop with one run, raising
what ended it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np

from . import interrupts
from .errors import OptimizerContractError
from .optimizer import Optimizer, check_compatible
from .problem import Problem


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
    stopped_by: str  # "budget", "target", "optimizer" or "max_batches"
    #: the run's own time (s) when each batch's values were booked, aligned with trace_*
    trace_seconds: list[float] = dataclasses.field(default_factory=list)


class RunTimeoutError(Exception):
    """A run went past its wall-time limit (the job's ``run_timeout_s``)."""


@dataclasses.dataclass
class Ledger:
    """The books of one run: the only place where evaluations are counted and the best kept."""

    budget: int
    dim: int
    used: int = 0
    batches: int = 0
    best_f: float = np.inf
    best_x: np.ndarray | None = None
    trace_n: list[int] = dataclasses.field(default_factory=list)
    trace_f: list[float] = dataclasses.field(default_factory=list)
    trace_s: list[float] = dataclasses.field(default_factory=list)
    stopped_by: str = "budget"
    seconds: float = 0.0  # the run's own time: its ask/tell and its share of evaluations
    #: the run ends once its best value is at most this (stop at the final target)
    stop_at: float = -np.inf

    @property
    def spent(self) -> bool:
        """True once the whole budget has been evaluated, or the final target reached."""
        return self.used >= self.budget or self.reached

    @property
    def reached(self) -> bool:
        """True once the best value is at most :attr:`stop_at`."""
        return self.best_f <= self.stop_at

    def admit(self, X: np.ndarray) -> tuple[np.ndarray, bool]:
        """The rows of ``X`` the budget allows, and whether ``X`` was cut (the run then ends)."""
        left = self.budget - self.used
        return (X[:left], True) if X.shape[0] > left else (X, False)

    def book(self, X: np.ndarray, f: np.ndarray) -> None:
        """Count the evaluated rows ``X`` with values ``f``; update the best and the trace.
        The first batch always sets a best vector (even when every value is ``inf``)."""
        self.used += X.shape[0]
        self.batches += 1
        i = int(f.argmin())
        if f[i] < self.best_f or self.batches == 1:
            self.best_f = float(f[i])
            self.best_x = X[i].copy()
        self.trace_n.append(self.used)
        self.trace_f.append(self.best_f)
        self.trace_s.append(self.seconds)
        if self.reached:
            self.stopped_by = "target"

    def result(self) -> RunResult:
        """The run so far, as a :class:`RunResult`."""
        x = self.best_x if self.best_x is not None else np.full(self.dim, np.nan)
        return RunResult(x_best=x, f_best=self.best_f, evaluations=self.used,
                         budget=self.budget, batches=self.batches,
                         trace_evaluations=self.trace_n, trace_best=self.trace_f,
                         wall_time_s=self.seconds, stopped_by=self.stopped_by,
                         trace_seconds=self.trace_s)


@dataclasses.dataclass
class Lane:
    """One run of :func:`run_many`: ``problem`` the instance it fits, ``instance`` its index
    for :meth:`~vpid_bench.api.Problem.evaluate_instances`, ``elapsed_s`` the seconds spent
    before the loop (counted against its limit), ``stop_at`` its final target's value."""

    problem: Problem
    optimizer: Optimizer
    budget: int
    instance: int = 0
    elapsed_s: float = 0.0
    stop_at: float = -np.inf


@dataclasses.dataclass
class _Run:
    """A lane in the loop: its ledger, its outcome once over, and the batch of this step."""

    lane: Lane
    ledger: Ledger
    residuals: bool = False
    outcome: RunResult | BaseException | None = None
    X: np.ndarray | None = None
    cut: bool = False

    def finish(self) -> None:
        self.outcome = self.ledger.result()

    @property
    def spent_s(self) -> float:
        """Seconds counted against the run's time limit: before the loop and in it."""
        return self.lane.elapsed_s + self.ledger.seconds


def check_proposal(X: object, optimizer: Optimizer, dim: int) -> np.ndarray:
    """A copy of ``ask()``'s answer as floats, or :class:`OptimizerContractError`."""
    name = getattr(optimizer, "name", type(optimizer).__name__)
    if not isinstance(X, np.ndarray):
        raise OptimizerContractError(f"optimizer {name!r}: ask() returned "
                                     f"{type(X).__name__}, expected a numpy array of shape "
                                     f"(n, {dim})")
    if X.ndim != 2 or X.shape[1] != dim or X.shape[0] < 1:
        raise OptimizerContractError(f"optimizer {name!r}: ask() returned shape {X.shape}, "
                                     f"expected (n, {dim}) with n >= 1")
    X = X.astype(float, copy=True)
    bounds = optimizer.bounds
    if ((X >= bounds.lower) & (X <= bounds.upper)).all():  # the usual case, in one pass
        return X  # (a NaN or an inf is never inside: it takes the path below)
    if not np.all(np.isfinite(X)):
        raise OptimizerContractError(f"optimizer {name!r}: ask() returned NaN or inf candidates")
    inside = bounds.contains(X)
    if not np.all(inside):
        row = int(np.flatnonzero(~inside)[0])
        raise OptimizerContractError(f"optimizer {name!r}: ask() returned candidate {row} "
                                     f"outside the bounds: {X[row]}")
    return X


def _values(problem: Problem, f: Any, n: int) -> np.ndarray:
    """``f`` checked to shape ``(n,)``, NaN mapped to ``inf`` (a failed evaluation); ``-inf``
    refused (it would be ranked best of every run: a broken problem, not a result)."""
    f = np.asarray(f, dtype=float).reshape(-1)
    if f.shape != (n,):
        raise ValueError(f"problem {problem.name!r}: evaluate() returned {f.shape}, "
                         f"expected ({n},)")
    if np.isfinite(f.sum()):  # the usual case, in one pass: no NaN, no inf
        return f.copy()  # never the problem's own buffer (it may reuse it)
    if np.any(f == -np.inf):
        raise ValueError(f"problem {problem.name!r}: evaluate() returned -inf (row "
                         f"{int(np.argmax(f == -np.inf))}); a value is finite, +inf or NaN "
                         "(both count as a failed evaluation)")
    return np.where(np.isnan(f), np.inf, f)


def _with_residuals(problem: Problem, X: np.ndarray, groups: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Values and residuals of the rows of ``X``, both checked against the problem's groups."""
    n = X.shape[0]
    f, R = problem.evaluate_with_residuals(X)
    R = np.asarray(R, dtype=float)
    if R.ndim != 2 or R.shape[0] != n:
        raise ValueError(f"problem {problem.name!r}: evaluate_with_residuals() returned "
                         f"residuals of shape {R.shape}, expected ({n}, m)")
    if R.shape[1] != groups.size:
        raise ValueError(f"problem {problem.name!r}: {R.shape[1]} residuals per row but "
                         f"residual_groups() has {groups.size} entries")
    return _values(problem, f, n), R


def run(problem: Problem, optimizer: Optimizer, budget: int, max_batches: int = 10**7) -> RunResult:
    """Run ``optimizer`` on ``problem`` until ``budget`` evaluations are used or it is done;
    raise whatever else ended the run. ``max_batches`` guards against an optimizer that is
    never done and asks for nothing new."""
    if budget < 1:
        raise ValueError(f"budget must be at least 1, got {budget}")
    outcome = run_many(problem, [Lane(problem, optimizer, budget)], max_batches=max_batches)[0]
    if isinstance(outcome, BaseException):
        raise outcome
    return outcome


class _Alarm:
    """A hard wall-time limit on one call: ``with alarm.limit(seconds):`` raises
    :class:`RunTimeoutError` inside it once ``seconds`` have passed (SIGALRM: POSIX main
    thread only; elsewhere only the soft check between steps applies)."""

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
        raise timeout_error(self.limit_s or 0.0)

    def arm(self, seconds: float | None) -> bool:
        """Start the limit of one call (``seconds`` from now); False: no limit applies."""
        if not self.enabled or seconds is None:
            return False
        signal.setitimer(signal.ITIMER_REAL, max(seconds, 1e-6))
        return True

    def disarm(self) -> None:
        """End the limit started by :meth:`arm`."""
        signal.setitimer(signal.ITIMER_REAL, 0)

    @contextlib.contextmanager
    def limit(self, seconds: float | None) -> Iterator[None]:
        armed = self.arm(seconds)
        try:
            yield
        finally:
            if armed:
                self.disarm()


@contextlib.contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`RunTimeoutError` after ``seconds`` of wall time (POSIX main thread)."""
    alarm = _Alarm(seconds)
    with alarm, alarm.limit(seconds):
        yield


def timeout_error(limit: float) -> RunTimeoutError:
    """The error of a run that went past ``limit`` seconds."""
    return RunTimeoutError(f"the run took longer than run_timeout_s={limit:g} s")


def run_many(problem: Problem, lanes: Sequence[Lane], timeout_s: float | None = None,
             max_batches: int = 10**7) -> list[RunResult | BaseException]:
    """Run every lane in lockstep (see module); one outcome per lane, in order: its
    :class:`RunResult`, or the exception that ended it.

    ``problem`` evaluates the gathered rows of the lanes that need only values; a lane that
    wants residuals is evaluated alone by its instance. A lane that raises fails alone (a
    gathered evaluation that raises is repeated lane by lane to find the culprit).
    ``timeout_s`` limits each run's own time (its ``ask``/``tell`` and its rows' share of the
    gathered evaluations): past it, :class:`RunTimeoutError`. ``KeyboardInterrupt`` stops the
    whole group (every optimizer closed first).
    """
    runs = [_start(lane, problem.bounds.dim) for lane in lanes]
    with _Alarm(timeout_s) as alarm:
        try:
            while True:
                asked = [r for r in runs if r.outcome is None
                         and _ask(r, alarm, timeout_s, max_batches)]
                if not asked:
                    break
                _evaluate_and_tell(problem, asked, alarm, timeout_s)
        finally:
            for r in runs:
                _close(r, alarm, timeout_s)
    return [r.outcome for r in runs]


def _start(lane: Lane, dim: int) -> _Run:
    """A lane ready for the loop, or already failed (no budget, residuals the problem lacks)."""
    r = _Run(lane, Ledger(lane.budget, dim, stop_at=lane.stop_at))
    if lane.budget < 1:
        r.outcome = ValueError(f"budget must be at least 1, got {lane.budget}")
        return r
    opt = lane.optimizer
    r.residuals = bool(getattr(opt, "wants_residuals", False))
    if r.residuals:
        try:
            check_compatible(lane.problem, opt)
            opt.residual_groups = np.asarray(lane.problem.residual_groups(), dtype=int).reshape(-1)
        except Exception as exc:  # noqa: BLE001 - this run only
            r.outcome = exc
    return r


#: A run already at its time limit still gets this long (s) to close its optimizer.
CLOSE_GRACE_S = 1.0


def _close(r: _Run, alarm: _Alarm, timeout_s: float | None) -> None:
    """The optimizer's ``close()``, as part of its run: its time counts, the run's limit
    applies (a ``close`` that sleeps past it fails the run), a failure fails the run."""
    close = getattr(r.lane.optimizer, "close", None)
    if close is None:
        return
    t0 = time.perf_counter()
    try:
        left = _remaining(r, timeout_s)
        with keep_cwd(), alarm.limit(None if left is None else max(left, CLOSE_GRACE_S)):
            close()
    except KeyboardInterrupt:
        if interrupts.from_user():
            raise
        if not isinstance(r.outcome, BaseException):
            r.outcome = interrupts.PluginInterruptError("close()")
    except BaseException as exc:  # noqa: BLE001 - a failing close fails its run only
        if not isinstance(r.outcome, BaseException):
            r.outcome = exc
    finally:
        r.ledger.seconds += time.perf_counter() - t0
    if (timeout_s is not None and r.spent_s > timeout_s
            and not isinstance(r.outcome, BaseException)):
        r.outcome = timeout_error(timeout_s)


@contextlib.contextmanager
def keep_cwd() -> Iterator[None]:
    """Put the working folder back if a plugin's call changed it (a plugin's ``os.chdir``
    once sent a relative sweep's files into the plugin's folder)."""
    before = os.getcwd()
    try:
        yield
    finally:
        if os.getcwd() != before:
            os.chdir(before)


def _remaining(r: _Run, timeout_s: float | None) -> float | None:
    return None if timeout_s is None else timeout_s - r.spent_s


def _guarded(r: _Run, alarm: _Alarm, timeout_s: float | None, fn: Callable[[], None]) -> bool:
    """Call ``fn()`` as run ``r`` (its time counted, its limit applied, the working folder
    kept); an exception ends the run and returns False. Written out rather than with context
    managers: it runs three times per batch, and those cost a quarter of DE's overhead."""
    t0 = time.perf_counter()
    cwd = os.getcwd()
    try:
        armed = alarm.arm(_remaining(r, timeout_s))
        try:
            fn()
        finally:
            if armed:
                alarm.disarm()
            if os.getcwd() != cwd:
                os.chdir(cwd)
    except KeyboardInterrupt:
        if interrupts.from_user():
            raise
        r.outcome = interrupts.PluginInterruptError("its run (ask, tell or an evaluation)")
        return False
    except BaseException as exc:  # noqa: BLE001 - crash isolation: this run only
        r.outcome = exc
        return False
    finally:
        r.ledger.seconds += time.perf_counter() - t0
    return _within(r, timeout_s)


def _within(r: _Run, timeout_s: float | None) -> bool:
    """False (the run ended by a timeout) once the run's own time is past ``timeout_s``."""
    if timeout_s is not None and r.spent_s > timeout_s:
        r.outcome = timeout_error(timeout_s)
        return False
    return True


def _ask(r: _Run, alarm: _Alarm, timeout_s: float | None, max_batches: int) -> bool:
    """The top of the loop for one run: stop (its outcome set), or ask and admit its batch."""
    ledger, opt = r.ledger, r.lane.optimizer
    r.X = None
    if ledger.spent:
        r.finish()
        return False

    def ask() -> None:
        if opt.done:
            ledger.stopped_by = "optimizer"
        elif ledger.batches >= max_batches:
            ledger.stopped_by = "max_batches"
        else:
            r.X, r.cut = ledger.admit(check_proposal(opt.ask(), opt, ledger.dim))

    if not _guarded(r, alarm, timeout_s, ask):
        return False
    if r.X is None:
        r.finish()
        return False
    return True


def _evaluate_and_tell(problem: Problem, asked: list[_Run], alarm: _Alarm,
                       timeout_s: float | None) -> None:
    """Evaluate this step's batches, then book each run and ``tell`` its optimizer."""
    gathered = [r for r in asked if not r.residuals]
    values = _gathered_values(problem, gathered, alarm, timeout_s) if gathered else {}
    for r in asked:
        R = None
        if r.residuals:
            out: dict[str, Any] = {}

            def evaluate(r: _Run = r, out: dict = out) -> None:
                groups = r.lane.optimizer.residual_groups
                out["f"], out["R"] = _with_residuals(r.lane.problem, r.X, groups)

            if not _guarded(r, alarm, timeout_s, evaluate):
                continue
            f, R = out["f"], out["R"]
        elif id(r) in values:
            f = values[id(r)]
        else:
            continue
        r.ledger.book(r.X, f)
        if not _within(r, timeout_s):
            continue
        if r.cut or r.ledger.reached:
            r.finish()
            continue
        kw = {} if R is None else {"residuals": R}  # f: the loop's own copy, booked already
        _guarded(r, alarm, timeout_s, functools.partial(r.lane.optimizer.tell, r.X, f, **kw))


def _gathered_values(problem: Problem, runs: list[_Run], alarm: _Alarm,
                     timeout_s: float | None) -> dict[int, np.ndarray]:
    """The values of ``runs``' batches (by ``id``), from one call, each run charged its share."""
    if len(runs) == 1:  # one run: its own instance evaluates it (no gathering)
        r = runs[0]
        out: dict[int, np.ndarray] = {}

        def alone() -> None:
            out[id(r)] = _values(r.lane.problem, r.lane.problem.evaluate(r.X), r.X.shape[0])

        _guarded(r, alarm, timeout_s, alone)
        return out
    X = np.concatenate([r.X for r in runs])
    sizes = [r.X.shape[0] for r in runs]
    index = np.repeat(np.array([r.lane.instance for r in runs], dtype=np.int64), sizes)
    limit = None if timeout_s is None else sum(_remaining(r, timeout_s) for r in runs)
    t0 = time.perf_counter()
    try:
        with alarm.limit(limit):
            f_all = _values(problem, problem.evaluate_instances(X, index), X.shape[0])
    except BaseException as exc:  # noqa: BLE001 - find the runs whose rows raise, fail them alone
        if isinstance(exc, KeyboardInterrupt) and interrupts.from_user():
            raise
        values = {}  # run by run, to fail only the culprits
        for r in runs:
            values.update(_gathered_values(problem, [r], alarm, timeout_s))
        return values
    share = (time.perf_counter() - t0) / X.shape[0]
    values = {}
    start = 0
    for r, n in zip(runs, sizes):
        r.ledger.seconds += share * n
        values[id(r)] = f_all[start:start + n]
        start += n
    return values
