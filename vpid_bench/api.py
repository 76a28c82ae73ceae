"""The two interfaces every plugin implements: :class:`Problem` and :class:`Optimizer`.

The core knows nothing about vehicles or evolutionary algorithms. A problem maps a population
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
        """``n`` candidates drawn uniformly in the box, shape ``(n, dim)``."""
        return self.lower + rng.random((n, self.dim)) * self.width


@dataclasses.dataclass(frozen=True)
class ProblemConfig:
    """Base of every problem's ``Config``: the benchmark protocol of that problem.

    ``ps`` is the population size optimizers read (by interpolation, ``${problem.ps}``) and
    ``iterations`` the number of generations after the initial population, so the default
    budget of a run is ``ps * (iterations + 1)`` evaluations.
    """

    ps: int = 20
    iterations: int = 50


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
        """The true parameter vector when it is known (enables NoRE), else ``None``."""
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
        has no signals (the default).
        """
        return None

    #: Optional capability for least-squares optimizers: a problem that sets this to True
    #: implements :meth:`residuals`. Each residual evaluation counts against the budget like
    #: a scalar one (the run loop will route it through the same counter).
    has_residuals: ClassVar[bool] = False

    def residuals(self, X: np.ndarray) -> np.ndarray:
        """Residual vectors (measured minus computed, per sample), shape ``(n, m)``."""
        raise NotImplementedError(f"problem {self.name!r} does not provide residuals")

    def set_threads(self, n: int) -> None:
        """How many threads ``evaluate`` may use for a large batch (``n >= 1``). The default
        ignores it; a problem that uses it must give the same results for every ``n``."""
        return None

    def describe(self) -> dict[str, Any]:
        """Extra facts about this instance that go into every run record (JSON-able)."""
        return {}

    def write_artifacts(self, directory: Path) -> list[Path]:
        """Write files a job should keep beside its records (e.g. the fitted reference)."""
        return []


@dataclasses.dataclass(frozen=True)
class OptimizerParams:
    """Base of every optimizer's ``Params``.

    ``ps`` and ``iterations`` default to the problem's protocol: the config node built for an
    optimizer sets them to ``${problem.ps}`` and ``${problem.iterations}``.
    """

    ps: int = 20
    iterations: int = 50


class Optimizer(abc.ABC):
    """An ask/tell optimizer over a box.

    The run loop calls ``ask()`` for a population (rows in physical units, inside
    ``bounds``), evaluates it, and calls ``tell(X, f)`` with the same rows and their
    objective values (``inf`` for failed candidates). It stops when the budget is spent or
    ``done`` is true. ``tell`` is not called for a partial population cut by the budget.
    """

    Params: ClassVar[type[OptimizerParams]] = OptimizerParams
    name: str = "optimizer"

    def __init__(self, params: OptimizerParams, bounds: Bounds, rng: np.random.Generator) -> None:
        self.params = params
        self.bounds = bounds
        self.rng = rng

    @abc.abstractmethod
    def ask(self) -> np.ndarray:
        """The next candidates to evaluate, shape ``(n, dim)`` with ``n >= 1``."""

    @abc.abstractmethod
    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        """Receive the objective values ``f`` (shape ``(n,)``) of the rows ``X`` from ``ask``."""

    @property
    def done(self) -> bool:
        """True when the optimizer has finished its own schedule (e.g. its generations)."""
        return False


class GenerationalOptimizer(Optimizer):
    """An optimizer that proposes whole generations: the shared ask/tell handshake.

    ``ask`` returns the pending generation (asking again before ``tell`` returns the same
    rows): first the initial population, ``ps`` vectors uniform in the box, then whatever
    :meth:`next_generation` builds. ``tell`` must receive that whole generation; it hands the
    proposed rows and their values to :meth:`start` (the initial population) or
    :meth:`advance` (every later generation, which also counts ``generation``). ``done`` is
    true after ``params.iterations`` generations, so a run uses the initial population plus
    ``iterations`` generations of evaluations.
    """

    def __init__(self, params: OptimizerParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        self.generation = 0  # generations completed after the initial population
        self._started = False
        self._pending: np.ndarray | None = None

    def initial_population(self) -> np.ndarray:
        """``ps`` candidates uniform in the box (clipped, so rounding cannot leave it)."""
        U = self.bounds.sample(self.rng, self.params.ps)
        return np.minimum(np.maximum(U, self.bounds.lower), self.bounds.upper)

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

    @property
    def done(self) -> bool:
        return self._started and self.generation >= self.params.iterations


def relative_errors_percent(x: Sequence[float], x_true: Sequence[float]) -> np.ndarray:
    """Relative error of each parameter, ``100 * (x - x_true) / x_true`` (percent)."""
    x = np.asarray(x, dtype=float)
    x_true = np.asarray(x_true, dtype=float)
    return 100.0 * (x - x_true) / x_true


def nore(x: Sequence[float], x_true: Sequence[float]) -> float:
    """Norm of relative errors (the paper's NoRE): Euclidean norm of the errors in percent."""
    return float(np.linalg.norm(relative_errors_percent(x, x_true)))
