"""The two interfaces every plugin implements: :class:`Problem` and :class:`Optimizer`.

The core knows no particular problem or optimization algorithm. A problem maps a population
of candidate vectors (rows) to objective values; an optimizer proposes populations (``ask``)
and learns their values (``tell``). The run loop in :mod:`vpid_bench.runner` sits between the
two and owns the evaluation budget, so an optimizer can neither overspend nor misreport.

Conventions
-----------
* Candidates are in physical units (kg, N/m, ...), rows of an ``(n, d)`` float array.
* Randomness is explicit: the optimizer receives a :class:`numpy.random.Generator`.
* Hyper-parameters are frozen dataclasses (``Optimizer.Params``, ``Problem.Config``), so an
  unknown or ill-typed key fails when the object is built (see :mod:`vpid_bench.params`).
"""

from __future__ import annotations

import abc
import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np


class VpidBenchError(Exception):
    """Base class of the errors this package raises on purpose (shown as one line by the CLI)."""


class ConfigError(VpidBenchError, ValueError):
    """A configuration value is not allowed. The message names the key, the value and what is
    allowed."""

    def __init__(self, key: str, value: Any, allowed: str) -> None:
        self.key, self.value, self.allowed = key, value, allowed
        super().__init__(f"{key}={value!r} is not allowed: {allowed}")


class PluginError(VpidBenchError):
    """A plugin could not be loaded or registered (name collision, bad registration)."""


class OptimizerContractError(VpidBenchError):
    """An optimizer broke the ask/tell contract (wrong shape, NaN, outside the box, ...)."""


@dataclasses.dataclass(frozen=True)
class Bounds:
    """A box in parameter space, with names and units for every coordinate.

    ``lower`` and ``upper`` are 1-D float arrays of equal length ``dim`` with
    ``lower < upper`` element-wise.
    """

    lower: np.ndarray
    upper: np.ndarray
    names: tuple[str, ...]
    units: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        lower = np.asarray(self.lower, dtype=float).reshape(-1)
        upper = np.asarray(self.upper, dtype=float).reshape(-1)
        names = tuple(self.names)
        units = tuple(self.units) if self.units else ("",) * len(names)
        if not (lower.shape == upper.shape and len(names) == lower.size == len(units)):
            raise ValueError(
                f"bounds: lower {lower.shape}, upper {upper.shape}, {len(names)} names and "
                f"{len(units)} units must all have the same length"
            )
        if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
            raise ValueError("bounds: lower and upper must be finite")
        bad = np.flatnonzero(~(lower < upper))
        if bad.size:
            i = int(bad[0])
            raise ConfigError(
                f"bounds.{names[i]}",
                (float(lower[i]), float(upper[i])),
                "lower bound must be strictly below the upper bound",
            )
        lower.setflags(write=False)
        upper.setflags(write=False)
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "units", units)

    @property
    def dim(self) -> int:
        """Number of parameters."""
        return int(self.lower.size)

    @property
    def width(self) -> np.ndarray:
        """``upper - lower``, per parameter."""
        return self.upper - self.lower

    def contains(self, X: np.ndarray) -> np.ndarray:
        """Boolean per row of ``X``: is the candidate inside the closed box?"""
        X = np.atleast_2d(X)
        return np.all((X >= self.lower) & (X <= self.upper), axis=1)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` candidates drawn uniformly in the box, shape ``(n, dim)``; never past a bound
        (``lower + u * width`` can round one ulp above ``upper``: it is clipped)."""
        X = self.lower + rng.random((n, self.dim)) * self.width
        return np.minimum(np.maximum(X, self.lower), self.upper)


@dataclasses.dataclass(frozen=True)
class ProblemConfig:
    """Base of every problem's ``Config``: the benchmark protocol of that problem.

    ``ps`` is the population size (candidates an optimizer proposes per generation) and
    ``iterations`` the number of generations after the initial population; the default budget
    of a run is :func:`default_budget` evaluations (see :mod:`vpid_bench.spec`).
    """

    ps: int = 20
    iterations: int = 50


#: The problem's protocol keys: stored in the problem's config only, copied into every
#: optimizer's ``Params`` by the job (never settable on the optimizer).
PROTOCOL_KEYS = ("ps", "iterations")
#: What the job fills into an optimizer's ``Params``: the protocol and the run's budget.
FILLED_PARAMS = (*PROTOCOL_KEYS, "budget")


def default_budget(ps: int, iterations: int) -> int:
    """The default evaluation budget of a run under a protocol: the initial population plus
    ``iterations`` generations of ``ps`` candidates, ``ps * (iterations + 1)``. The only place
    this formula is written; an optimizer reads its run's budget from ``params.budget``."""
    return ps * (iterations + 1)


class Problem(abc.ABC):
    """An objective to minimise over a box.

    Subclasses set ``Config`` (a frozen dataclass deriving from :class:`ProblemConfig`) and
    build themselves from an instance of it. ``evaluate`` takes a whole population at once.
    """

    Config: ClassVar[type[ProblemConfig]] = ProblemConfig
    name: str = "problem"

    def __init__(self, config: ProblemConfig) -> None:
        self.config = config

    @property
    @abc.abstractmethod
    def bounds(self) -> Bounds:
        """The search box, with parameter names and units."""

    @property
    def x_true(self) -> np.ndarray | None:
        """The true parameter vector when it is known (the records then hold each parameter's
        relative error), else ``None``."""
        return None

    @abc.abstractmethod
    def evaluate(self, X: np.ndarray) -> np.ndarray:
        """Objective values of the rows of ``X`` (shape ``(n, dim)``), shape ``(n,)``.

        A candidate whose simulation fails gets ``inf``; this method should not raise for a
        candidate inside the bounds.
        """

    def signals(self, x: np.ndarray) -> dict[str, np.ndarray] | None:
        """Optional, for plots: the measured reference and the response computed at ``x``.

        Returns ``{"t": times (s), "<channel>:measured": ..., "<channel>:fitted": ...}`` with
        one pair per measured channel (e.g. ``z1'':measured``), or ``None`` when the problem
        has no signals (the default). Every array has the length of ``t``. At the end of a job
        the signals of its best run are written to ``best_signals.csv``
        (:func:`vpid_bench.artifacts.write_best_signals`), which report sections plot.
        """
        return None

    def signal_units(self) -> dict[str, str]:
        """Unit of each channel of :meth:`signals`, e.g. ``{"z1''": "m/s^2"}``; a channel
        missing here has no unit in files and plots. Default: none."""
        return {}

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        """Named accuracy metrics of an identified vector ``x`` (lower is better), e.g. an
        error norm against the known truth. Stored in each run record as ``result.metrics``
        (a non-finite value as ``null``); the report ranks by the first metric where every
        run of a context has it, else by the objective. Default: none."""
        return {}

    # -- residual-aware evaluation (least-squares optimizers) ---------------------------------
    def residuals(self, X: np.ndarray) -> np.ndarray:
        """Residual vectors of the rows of ``X`` (measured minus computed, in the problem's
        units), shape ``(n, m)``. Optional: a problem that overrides this has residuals
        (:attr:`has_residuals`) and can serve an optimizer with ``wants_residuals``."""
        raise NotImplementedError(f"problem {self.name!r} does not provide residuals")

    @property
    def has_residuals(self) -> bool:
        """True when this problem's class overrides :meth:`residuals`."""
        return offers_residuals(self)

    def residual_groups(self) -> np.ndarray:
        """The group (channel) of each residual entry, int array of shape ``(m,)``.

        An objective that is a sum of group norms (e.g. one norm per
        measured channel) tells least-squares optimizers which entries share a norm. The
        default is one group (all zeros); it learns ``m`` from one residual evaluation at the
        lower corner of the box, made once and not counted (override it when ``m`` is known).
        """
        if not hasattr(self, "_residual_groups_default"):
            m = np.asarray(self.residuals(self.bounds.lower[None].copy())).shape[1]
            self._residual_groups_default = np.zeros(m, dtype=int)
        return self._residual_groups_default.copy()

    def evaluate_with_residuals(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Objective values ``(n,)`` and residuals ``(n, m)`` of the rows of ``X``.

        The default calls :meth:`residuals` and :meth:`evaluate`; a problem whose objective
        is a function of its residuals overrides this to compute both from one simulation.
        """
        return np.asarray(self.evaluate(X), dtype=float), np.asarray(self.residuals(X), float)

    def residual_sigma(self) -> np.ndarray | None:
        """The standard deviation of the measurement noise in each residual group (units of
        the residuals), shape ``(groups,)``, for the Fisher information; ``None`` when it is
        not known (a measured record)."""
        return None

    def instance(self, index: int) -> Problem:
        """Instance ``index`` of this problem (as COCO and IOHprofiler have them): run ``i`` of
        every optimizer in a comparison fits instance ``i``, so runs pair by instance across
        optimizers. An instance differs in its data (a noise record), never in its settings.
        Default: the problem itself, every instance identical."""
        return self

    #: True when ``evaluate`` gives each row a value that depends only on that row (and the
    #: instance): not on the other rows of the call, their order or count, nor on earlier
    #: calls. Then a job may run its runs in lockstep, gathering their batches into one call
    #: (:func:`vpid_bench.runner.run_many`), and records stay bit-identical. Default False:
    #: a problem must say so (a noisy objective drawing from its own generator must not).
    rows_independent: ClassVar[bool] = False

    def evaluate_instances(self, X: np.ndarray, instance: np.ndarray) -> np.ndarray:
        """Objective values of the rows of ``X`` (shape ``(n, dim)``), row ``j`` against
        instance ``instance[j]`` (int array ``(n,)``), shape ``(n,)``: the gathered call of runs
        in lockstep. Must equal ``self.instance(instance[j]).evaluate(X[j:j+1])`` for each row.

        The default groups the rows by instance (instances that are the same object, e.g. the
        problem itself, form one group) and calls each group's ``evaluate`` once. A problem
        whose instances share an expensive part overrides it to evaluate every row in one go.
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        instance = np.asarray(instance, dtype=np.int64).reshape(-1)
        if instance.shape != (X.shape[0],):
            raise ValueError(f"evaluate_instances: {instance.shape[0]} instance indices for "
                             f"{X.shape[0]} rows")
        groups: dict[int, tuple[Problem, list[int]]] = {}
        for i in np.unique(instance):
            inst = self.instance(int(i))
            groups.setdefault(id(inst), (inst, []))[1].append(int(i))
        if len(groups) == 1:
            inst = next(iter(groups.values()))[0]
            return np.asarray(inst.evaluate(X), dtype=float).reshape(-1)
        f = np.empty(X.shape[0])
        for inst, indices in groups.values():
            rows = np.flatnonzero(np.isin(instance, indices))
            f[rows] = np.asarray(inst.evaluate(X[rows]), dtype=float).reshape(-1)
        return f

    def instance_id(self) -> str | None:
        """A short, stable name of this instance's data, stored in every record (runs with the
        same id fit the same data); ``None`` when all instances are identical."""
        return None

    def describe(self) -> dict[str, Any]:
        """Extra facts about this instance that go into every run record (JSON-able), under
        ``problem.info``. Two keys are read by the report: ``f_at_true`` (the objective at
        :attr:`x_true`, where known), drawn as a reference line in the convergence figure, and
        ``metric_units`` (``{"rms_error": "%"}``: the unit of each of :meth:`metrics`), printed
        beside every metric value."""
        return {}

    def write_artifacts(self, directory: Path) -> list[Path]:
        """Write files a job should keep beside its records (e.g. the fitted reference)."""
        return []

    def content_digest(self) -> str | None:
        """A digest of the data this problem reads beyond its config (e.g. the SHA-256 of a
        measured record file), or ``None``. It enters every run id, so editing the data makes
        a resumed job run again instead of reusing results from the old data."""
        return None

    def set_threads(self, n: int) -> None:
        """How many threads ``evaluate`` may use (the job's ``threads`` key); results must not
        depend on it. Default: ignored."""
        return None


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


def offers_residuals(problem: Problem | type[Problem]) -> bool:
    """Whether a problem (an instance or its class) implements :meth:`Problem.residuals`."""
    cls = problem if isinstance(problem, type) else type(problem)
    return getattr(cls, "residuals", None) is not Problem.residuals


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


def relative_errors_percent(x: Sequence[float], x_true: Sequence[float]) -> np.ndarray:
    """Relative error of each parameter, ``100 * (x - x_true) / x_true`` (percent)."""
    x = np.asarray(x, dtype=float)
    x_true = np.asarray(x_true, dtype=float)
    return 100.0 * (x - x_true) / x_true

# The bridge for optimizers that own their loop lives in its own module; it is part of this API.
from .bridge import LoopOptimizer  # noqa: E402, F401

# Plugins write their files (artifacts) the way records are written: atomically, never
# through a planted link.
from .fileio import write_text_atomic  # noqa: E402, F401
