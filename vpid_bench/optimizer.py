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
    """Base of every optimizer's ``Params``: ``ps`` and ``iterations`` (the problem's
    protocol) and ``budget`` (the evaluations the run loop allows this run), filled in by the
    job, none settable on the optimizer. ``budget`` is ``None`` only in Params built by hand;
    an optimizer that plans over its budget reads :attr:`Optimizer.budget`."""

    ps: int = 20
    iterations: int = 50
    budget: int | None = None


class Optimizer(abc.ABC):
    """An ask/tell optimizer over a box: the run loop calls ``ask()`` for a population (rows
    in physical units, inside ``bounds``) and ``tell(X, f)`` with its values until the budget
    is spent or ``done`` is true, then :meth:`close` (the whole contract: docs/plugins.md)."""

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
        """Evaluations the run loop allows this run (``params.budget``, else the protocol's
        default), for optimizers that plan over it."""
        budget = getattr(self.params, "budget", None)
        if budget is None:
            budget = default_budget(self.params.ps, self.params.iterations)
        return int(budget)

    @classmethod
    def check(cls, params: OptimizerParams) -> None:
        """Checks that need the class as well as its ``Params`` (e.g. the smallest population
        it works with): raise :class:`ConfigError`. The pre-flight calls it for every job
        before any runs, so prefer it to checks in ``__init__``."""
        return None

    @abc.abstractmethod
    def ask(self) -> np.ndarray:
        """The next candidates to evaluate, shape ``(n, dim)`` with ``n >= 1``."""

    @abc.abstractmethod
    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        """Receive the objective values ``f`` (shape ``(n,)``) of the rows ``X`` from ``ask``
        (and ``residuals=R``, shape ``(n, m)``, when ``wants_residuals``)."""

    def close(self) -> None:
        """Release what the optimizer holds (a thread, ...) once the run is over."""
        return None

    @property
    def done(self) -> bool:
        """True when the optimizer wants its run to end (read before every ``ask``);
        settable: ``self.done = True``."""
        return self._done

    @done.setter
    def done(self, value: bool) -> None:
        self._done = bool(value)


class GenerationalOptimizer(Optimizer):
    """An optimizer that proposes whole generations: the shared ask/tell handshake.

    ``ask`` returns the pending generation (the same rows until ``tell``): first ``ps``
    vectors uniform in the box, then :meth:`next_generation`'s. ``tell`` takes that whole
    generation and hands it to :meth:`start` (the initial one) or :meth:`advance` (later
    ones, counted in ``generation``). ``done`` after ``params.iterations`` generations (or
    ``self.done = True``).
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
        """True after ``params.iterations`` generations, or once ``self.done = True``."""
        return self._done or (self._started and self.generation >= self.params.iterations)


def check_compatible(
    problem: Problem | type[Problem], optimizer: type[Optimizer] | Optimizer,
    name: str | None = None, problem_name: str | None = None,
) -> None:
    """Refuse (:class:`ConfigError`, key ``optimizer``) an optimizer that wants residuals on
    a problem that has none. Classes or instances; ``name`` and ``problem_name``: the names
    the user typed (default: their ``name``)."""
    if not getattr(optimizer, "wants_residuals", False) or offers_residuals(problem):
        return
    if name is None:
        name = getattr(optimizer, "name", None)
        if name in (None, Optimizer.name):
            name = optimizer.__name__ if isinstance(optimizer, type) else type(optimizer).__name__
    if problem_name is None:
        problem_name = getattr(problem, "name", type(problem).__name__)
    raise ConfigError("optimizer", name, f"optimizer {name!r} fits residual vectors and "
                      f"problem {problem_name!r} has none (it does not implement "
                      "residuals()); pick an optimizer that needs only f")
