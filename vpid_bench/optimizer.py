"""The optimizer interface: :class:`Optimizer` (ask/tell), :class:`GenerationalOptimizer`, the
parameters the job fills in (:class:`OptimizerParams`), and the residuals compatibility check."""

from __future__ import annotations

import abc
import dataclasses
from typing import ClassVar

import numpy as np

from .bounds import Bounds
from .errors import ConfigError
from .problem import Problem, default_budget, offers_residuals


@dataclasses.dataclass(frozen=True)
class OptimizerParams:
    """Base of every optimizer's ``Params``.

    ``ps`` and ``iterations`` are a copy of the problem's protocol and ``budget`` the number of
    evaluations the run loop will allow this run, all three filled in by the job
    (:func:`vpid_bench.spec.parse_job`); none is settable on the optimizer. An optimizer that
    plans over its budget (a population-size schedule, a library's own budget) reads
    :attr:`Optimizer.budget`, never a formula of its own. ``budget`` is ``None`` only when the
    Params were built by hand; :attr:`Optimizer.budget` then falls back to the protocol's
    default (:func:`default_budget`).
    """

    ps: int = 20
    iterations: int = 50
    budget: int | None = None


class Optimizer(abc.ABC):
    """An ask/tell optimizer over a box.

    The run loop calls ``ask()`` for a population (rows in physical units, inside
    ``bounds``), evaluates it, and calls ``tell(X, f)`` with the same rows and their
    objective values (``inf`` for failed candidates). It stops when the budget is spent or
    ``done`` is true. ``tell`` is not called for a partial population cut by the budget.
    An optimizer that has converged ends its run early by writing ``self.done = True``.

    An optimizer that sets ``wants_residuals = True`` gets residual vectors too: the run loop
    evaluates each batch with :meth:`Problem.evaluate_with_residuals`, calls
    ``tell(X, f, residuals=R)`` (``R`` of shape ``(n, m)``; each row still one evaluation) and,
    before the first ``ask``, stores the problem's ``residual_groups()`` in
    ``self.residual_groups``. A problem without residuals is refused before the run
    (:func:`check_compatible`). When the run ends, normally or not, the run loop calls
    :meth:`close`.
    """

    Params: ClassVar[type[OptimizerParams]] = OptimizerParams
    name: str = "optimizer"
    _done: bool = False  # what ``self.done = ...`` stored (class default: not done)
    #: True: ``tell`` receives ``residuals=R`` beside ``f`` (the problem must have residuals).
    wants_residuals: ClassVar[bool] = False
    #: The distribution name of the third-party library that runs the search (``"cma"``,
    #: ``"nevergrad"``, ``"scipy"``), or ``None`` for an optimizer written here: its installed
    #: version is in every record (``optimizer.plugin.library``), so a record names what ran.
    library: ClassVar[str | None] = None
    #: Set by the run loop when ``wants_residuals``: the group of each residual entry, ``(m,)``.
    residual_groups: np.ndarray | None = None

    def __init__(self, params: OptimizerParams, bounds: Bounds, rng: np.random.Generator) -> None:
        self.params = params
        self.bounds = bounds
        self.rng = rng

    @property
    def budget(self) -> int:
        """Evaluations the run loop allows this run (``params.budget``; built by hand without
        one: the protocol's default, :func:`default_budget`). The loop stops the run there
        whatever the optimizer does; this is for optimizers that plan over it."""
        budget = getattr(self.params, "budget", None)
        if budget is None:
            budget = default_budget(self.params.ps, self.params.iterations)
        return int(budget)

    @classmethod
    def check(cls, params: OptimizerParams) -> None:
        """Checks that need the class as well as its ``Params`` (e.g. the smallest population
        a strategy can work with); raise :class:`ConfigError`. The pre-flight calls it for
        every job of a sweep before any job runs, so prefer it to checks in ``__init__``."""
        return None

    @abc.abstractmethod
    def ask(self) -> np.ndarray:
        """The next candidates to evaluate, shape ``(n, dim)`` with ``n >= 1``."""

    @abc.abstractmethod
    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        """Receive the objective values ``f`` (shape ``(n,)``) of the rows ``X`` from ``ask``
        (and ``residuals=R``, shape ``(n, m)``, when ``wants_residuals``)."""

    def close(self) -> None:
        """Release what the optimizer holds (a worker thread, ...); the run loop calls it once
        the run is over, however it ended. The default does nothing."""
        return None

    @property
    def done(self) -> bool:
        """True when the optimizer wants its run to end; the run loop reads it before every
        ``ask``. Settable: ``self.done = True`` (e.g. in ``tell``, once converged)."""
        return self._done

    @done.setter
    def done(self, value: bool) -> None:
        self._done = bool(value)


class GenerationalOptimizer(Optimizer):
    """An optimizer that proposes whole generations: the shared ask/tell handshake.

    ``ask`` returns the pending generation (asking again before ``tell`` returns the same
    rows): first the initial population, ``ps`` vectors uniform in the box, then whatever
    :meth:`next_generation` builds. ``tell`` must receive that whole generation; it hands the
    proposed rows and their values to :meth:`start` (the initial population) or
    :meth:`advance` (every later generation, which also counts ``generation``). ``done`` is
    true after ``params.iterations`` generations, so a run uses the initial population plus
    ``iterations`` generations of evaluations; a subclass may end it sooner with
    ``self.done = True``.
    """

    def __init__(self, params: OptimizerParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        self.generation = 0  # generations completed after the initial population
        self._started = False
        self._pending: np.ndarray | None = None

    def initial_population(self) -> np.ndarray:
        """``ps`` candidates uniform in the box."""
        return self.bounds.sample(self.rng, self.params.ps)

    @abc.abstractmethod
    def next_generation(self) -> np.ndarray:
        """The candidates of the next generation, built from what ``start``/``advance`` kept."""

    @abc.abstractmethod
    def start(self, X: np.ndarray, f: np.ndarray) -> None:
        """Keep the evaluated initial population."""

    @abc.abstractmethod
    def advance(self, X: np.ndarray, f: np.ndarray) -> None:
        """Take in one evaluated generation (selection, elitism, bookkeeping)."""

    def ask(self) -> np.ndarray:
        if self._pending is None:
            self._pending = self.next_generation() if self._started else self.initial_population()
        return self._pending.copy()

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        if self._pending is None or X.shape != self._pending.shape:
            raise ValueError("tell() must follow ask() with the whole population it returned")
        f = np.asarray(f, dtype=float).reshape(-1)
        X = self._pending  # the rows this optimizer proposed (the runner evaluates copies)
        if self._started:
            self.advance(X, f)
            self.generation += 1
        else:
            self.start(X, f)
            self._started = True
        self._pending = None

    @Optimizer.done.getter
    def done(self) -> bool:
        """True after ``params.iterations`` generations, or once a subclass set
        ``self.done = True`` (the setter is the base class's)."""
        return self._done or (self._started and self.generation >= self.params.iterations)


def check_compatible(
    problem: Problem | type[Problem], optimizer: type[Optimizer] | Optimizer,
    name: str | None = None, problem_name: str | None = None,
) -> None:
    """Refuse an optimizer that wants residuals on a problem that has none, before any run.

    ``problem`` and ``optimizer`` are classes or instances; ``name`` and ``problem_name`` the
    names the user typed (default: their ``name``). Raises :class:`ConfigError` with key
    ``optimizer``, naming both. The pre-flight calls it with the classes, the run loop again.
    """
    if not getattr(optimizer, "wants_residuals", False) or offers_residuals(problem):
        return
    if name is None:
        name = getattr(optimizer, "name", None)
        if name in (None, Optimizer.name):
            name = optimizer.__name__ if isinstance(optimizer, type) else type(optimizer).__name__
    if problem_name is None:
        problem_name = getattr(problem, "name", type(problem).__name__)
    raise ConfigError(
        "optimizer",
        name,
        f"optimizer {name!r} fits residual vectors and problem {problem_name!r} has none "
        "(it does not implement residuals()); pick an optimizer that needs only f",
    )
