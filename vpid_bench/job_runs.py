"""A job's runs: which go together, the warm-up before them, and each run's outcome.

Every run goes through :func:`vpid_bench.runner.run_many`: in lockstep when the problem's
rows are independent and the optimizer asks and tells in the loop's thread (no
:class:`~vpid_bench.api.LoopOptimizer`, no residuals), else one at a time; a record is
bit-identical either way (tested), a run's time its own (constructor, ask, tell, its rows'
share of each evaluation). One untimed warm-up run first compiles the kernels (numba). What
the problem says of a run's best vector is computed where the run ran (in its worker).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import logging
import math
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import interrupts
from .analysis.intervals import jacobian_intervals
from .bridge import LoopOptimizer
from .build import run_rng
from .errors import PluginError
from .facts import ProblemFacts
from .problem import Problem, kept_instance, offers_residuals
from .runner import Lane, RunResult, run, run_many, time_limit, timeout_error
from .spec import Job

log = logging.getLogger(__name__)


@dataclasses.dataclass
class RunOutcome:
    """How run ``index`` ended: its result or exception, when it started (UTC, ISO 8601),
    its own time (s), and what the problem says of its best vector (``derived``)."""

    index: int
    outcome: RunResult | BaseException
    started_at: str
    seconds: float
    derived: dict[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def result(self) -> RunResult | None:
        return self.outcome if isinstance(self.outcome, RunResult) else None

    @property
    def error(self) -> BaseException | None:
        return None if isinstance(self.outcome, RunResult) else self.outcome


def joins_lockstep(job: Job, problem: Problem | ProblemFacts) -> bool:
    """Whether the runs of ``job`` can run in lockstep (see module)."""
    cls = job.optimizer_cls
    return (bool(getattr(problem, "rows_independent", False))
            and not getattr(cls, "wants_residuals", False)
            and not issubclass(cls, LoopOptimizer))


def warm_up(job: Job, problem: Problem, lockstep: bool = False) -> float:
    """One untimed run of at most two batches (in lockstep also one gathered call over two
    instances); its wall time (s). A fault here is left for the timed runs to record."""
    t0 = time.perf_counter()
    try:
        # its warnings too are left for the timed runs, which say them in one line per group
        # (cma's InjectionWarning, 8 raw lines per nevergrad warm-up, filled the build's log)
        with time_limit(job.spec.run_timeout_s), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if lockstep:
                X = problem.bounds.sample(np.random.default_rng(0), 2)
                problem.evaluate_instances(X, np.array([0, min(1, job.spec.runs - 1)]))
            optimizer = job.optimizer_cls(job.params, problem.bounds, run_rng(job.spec.seed, 2**31))
            run(problem, optimizer, min(job.budget, 2 * job.problem_config.ps))
    except Exception:  # noqa: BLE001 - the timed runs will meet and record the same fault
        log.debug("warm-up failed", exc_info=True)
    return time.perf_counter() - t0


#: The most of a plugin warning's text quoted in the log line of its group (characters).
WARNING_CHARS = 160


def run_outcomes(job: Job, problem: Problem, indices: Sequence[int], lockstep: bool,
                 announce: Callable[[str], None] | None = None) -> Iterator[RunOutcome]:
    """The outcome of each run in ``indices``, in order, with its metrics: in one lockstep
    group or one at a time. ``announce("metrics")`` before each run's metrics (a worker tells
    its supervisor whom to blame if the process ends)."""
    groups = [list(indices)] if lockstep else [[i] for i in indices]
    for group in groups:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("default")  # each place once
            outcomes = _group(job, problem, group)
        if caught:  # one log line for the warnings plugin code raised (not dozens)
            first = caught[0]
            runs = f"run {group[0]}" if len(group) == 1 else f"runs {group[0]}-{group[-1]}"
            text = " ".join(str(first.message).split())  # one line (cma's advice runs to six)
            text = text if len(text) <= WARNING_CHARS else text[:WARNING_CHARS - 3] + "..."
            log.warning("%s on %s, %s: %d warning(s) from plugin code (first: %s: %s, %s:%d); "
                        "the runs are recorded", job.optimizer_name, job.problem_name, runs,
                        len(caught), first.category.__name__, text, Path(first.filename).name,
                        first.lineno)
        for outcome in outcomes:
            if outcome.result is not None and announce is not None:
                announce("metrics")
            yield with_problem_results(job, problem, outcome)


def with_problem_results(job: Job, problem: Problem, outcome: RunOutcome) -> RunOutcome:
    """``outcome`` with what the problem says of its (finite) best vector, under the run's
    time limit: ``metrics`` and, without a truth and with residuals, the parameters'
    ``intervals``. Problem code that raises or passes the limit here fails the run."""
    result = outcome.result
    if result is None or not np.all(np.isfinite(result.x_best)):
        return outcome
    inst = kept_instance(problem, outcome.index)
    x = np.asarray(result.x_best, dtype=float)
    try:
        with time_limit(job.spec.run_timeout_s):
            derived: dict[str, Any] = {"metrics": {str(k): float(v) for k, v in
                                                   (inst.metrics(x) or {}).items()}}
            if (inst.x_true is None and offers_residuals(inst)
                    and getattr(inst, "fits_a_record", True)):
                derived["intervals"] = _intervals(inst, x)
    except KeyboardInterrupt:
        if interrupts.from_user():
            raise
        error: BaseException = interrupts.PluginInterruptError("its metrics()")
    except BaseException as exc:  # noqa: BLE001 - crash isolation: this run only
        error = PluginError(f"problem {job.problem_name!r}: metrics() or residuals() at run "
                            f"{outcome.index}'s best vector raised {type(exc).__name__}: {exc}")
        error.__cause__ = exc
    else:
        return dataclasses.replace(outcome, derived=derived)
    log.error("run %d of %s on %s failed: %s", outcome.index, job.optimizer_name,
              job.problem_name, error)
    return dataclasses.replace(outcome, outcome=error)


def _intervals(problem: Problem, x: np.ndarray) -> dict[str, Any] | None:
    """The parameters' intervals at ``x``, ``None`` where a simulation near ``x`` fails."""
    try:
        return jacobian_intervals(problem, x)
    except (ValueError, FloatingPointError, np.linalg.LinAlgError):
        return None


def now_utc() -> str:
    """The time now, UTC, ISO 8601 (when a run started)."""
    return _dt.datetime.now(_dt.timezone.utc).isoformat()


def _group(job: Job, problem: Problem, indices: list[int]) -> list[RunOutcome]:
    """Build an optimizer per run (one that raises or passes the time limit fails its run
    alone), then run the group through the one run loop."""
    timeout = job.spec.run_timeout_s
    started = now_utc()
    lanes: list[Lane] = []
    failed: dict[int, BaseException] = {}
    built_s: dict[int, float] = {}
    for i in indices:
        inst = kept_instance(problem, i)
        t0 = time.perf_counter()
        try:
            with time_limit(timeout):
                optimizer = job.optimizer_cls(job.params, inst.bounds, run_rng(job.spec.seed, i))
            optimizer.name = job.optimizer_name
            lanes.append(Lane(inst, optimizer, job.budget, instance=i,
                              elapsed_s=time.perf_counter() - t0,
                              stop_at=job.stop_at.get(i, -math.inf)))
        except KeyboardInterrupt:
            if interrupts.from_user():
                raise
            failed[i] = interrupts.PluginInterruptError("its constructor")
        except BaseException as exc:  # noqa: BLE001 - crash isolation: this run only
            failed[i] = exc
        built_s[i] = time.perf_counter() - t0
        if timeout is not None and i not in failed and built_s[i] > timeout:
            lanes.pop()
            failed[i] = timeout_error(timeout)
    outcomes = dict(zip([lane.instance for lane in lanes],
                        run_many(problem, lanes, timeout_s=timeout)))
    outcomes.update(failed)
    out = []
    for i in indices:
        o = outcomes[i]
        seconds = built_s[i] + (o.wall_time_s if isinstance(o, RunResult) else 0.0)
        if not isinstance(o, RunResult):
            log.error("run %d of %s on %s failed: %s: %s", i, job.optimizer_name,
                      job.problem_name, type(o).__name__, o)
        out.append(RunOutcome(i, o, started, seconds))
    return out
