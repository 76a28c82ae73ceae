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
"""

from __future__ import annotations

import dataclasses
import time
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
