"""The problem interface: :class:`Problem`, its protocol (:class:`ProblemConfig`) and the one
formula of a run's default budget (:func:`default_budget`)."""

from __future__ import annotations

import abc
import dataclasses
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .bounds import Bounds

#: Instances :func:`kept_instance` keeps built per problem (more than a job runs at once in
#: lockstep; past it the kept ones are dropped and built again).
KEPT_INSTANCES = 256


@dataclasses.dataclass(frozen=True)
class ProblemConfig:
    """Base of every problem's ``Config``: its benchmark protocol, ``ps`` (the population
    size) and ``iterations`` (generations after the initial population)."""

    ps: int = 20
    iterations: int = 50


#: The problem's protocol keys: stored in the problem's config only, copied into every
#: optimizer's ``Params`` by the job (never settable on the optimizer).
PROTOCOL_KEYS = ("ps", "iterations")
#: What the job fills into an optimizer's ``Params``: the protocol and the run's budget.
FILLED_PARAMS = (*PROTOCOL_KEYS, "budget")


def default_budget(ps: int, iterations: int) -> int:
    """A run's default evaluation budget, ``ps * (iterations + 1)`` (the one place this
    formula is written; an optimizer reads its run's budget from ``params.budget``)."""
    return ps * (iterations + 1)


class Problem(abc.ABC):
    """An objective to minimise over a box. Subclasses set ``Config`` (a frozen dataclass
    deriving from :class:`ProblemConfig`) and are built from one; ``evaluate`` takes a whole
    population at once."""

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
        """The true parameter vector when known (records then hold relative errors), else
        ``None``: a problem **without a truth** (a measured record; docs/architecture.md)."""
        return None

    @abc.abstractmethod
    def evaluate(self, X: np.ndarray) -> np.ndarray:
        """Objective values ``(n,)`` of the rows of ``X`` ``(n, dim)``; a candidate whose
        simulation fails gets ``inf`` (this should not raise for one inside the bounds)."""

    def signals(self, x: np.ndarray) -> dict[str, np.ndarray] | None:
        """Optional, for plots: ``{"t": times (s), "<channel>:measured": ...,
        "<channel>:fitted": ...}`` at ``x``, every array of the length of ``t``, or ``None``
        (the default). The best run's go to ``best_signals.csv``."""
        return None

    def signal_units(self) -> dict[str, str]:
        """Unit of each channel of :meth:`signals`, e.g. ``{"z1''": "m/s^2"}``; a channel
        missing here has no unit in files and plots. Default: none."""
        return {}

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        """Named accuracy metrics of an identified vector ``x`` (lower is better), e.g. an
        error norm against the truth; without a truth, errors on held-out data. Default: none."""
        return {}

    def comparisons(self) -> dict[str, dict[str, Any]]:
        """Named fixed comparison rows, neither runs nor truths, e.g. ``{"published
        estimate": {"x": [...], "note": "..."}, "naive predictor": {"metrics": {...}}}``. A
        row's ``x`` (physical units) gets its objective and :meth:`metrics` computed (the
        row's own ``metrics`` override them); the report prints them beside the ranking."""
        return {}

    # -- residual-aware evaluation (least-squares optimizers) ---------------------------------
    def residuals(self, X: np.ndarray) -> np.ndarray:
        """Residual vectors ``(n, m)`` of the rows of ``X`` (measured minus computed).
        Optional: a problem that overrides it can serve an optimizer ``wants_residuals``."""
        raise NotImplementedError(f"problem {self.name!r} does not provide residuals")

    @property
    def has_residuals(self) -> bool:
        """True when this problem's class overrides :meth:`residuals`."""
        return offers_residuals(self)

    def residual_groups(self) -> np.ndarray:
        """The group (channel) of each residual entry, ints ``(m,)``: which entries share a
        norm of an objective summing group norms. Default: one group, ``m`` learnt from one
        uncounted residual evaluation at the box's lower corner."""
        if not hasattr(self, "_residual_groups_default"):
            m = np.asarray(self.residuals(self.bounds.lower[None].copy())).shape[1]
            self._residual_groups_default = np.zeros(m, dtype=int)
        return self._residual_groups_default.copy()

    def evaluate_with_residuals(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Objective values ``(n,)`` and residuals ``(n, m)`` of the rows of ``X`` (override
        to compute both from one simulation)."""
        return np.asarray(self.evaluate(X), dtype=float), np.asarray(self.residuals(X), float)

    def fisher_residuals(self, X: np.ndarray) -> np.ndarray:
        """Measured minus computed ``(n, m)`` with weights that depend neither on the
        parameters nor the objective, in :meth:`residual_sigma`'s units: what the Fisher
        information and the profile likelihood differentiate. Default: :meth:`residuals`."""
        return self.residuals(X)

    def fisher_groups(self) -> np.ndarray:
        """The group (channel) of each entry of :meth:`fisher_residuals`, ints ``(m,)``.
        Default: :meth:`residual_groups`."""
        return self.residual_groups()

    def residual_sigma(self) -> np.ndarray | None:
        """The simulated noise's standard deviation per group of :meth:`fisher_groups`
        ``(groups,)`` or per entry ``(m,)``, in :meth:`fisher_residuals`' units, whatever the
        objective; ``None`` when unknown (a measured record)."""
        return None

    def instance(self, index: int) -> Problem:
        """Instance ``index`` (as COCO has them): run ``i`` of every optimizer fits instance
        ``i``. An instance differs in its data (a noise record), never in its settings.
        Default: the problem itself."""
        return self

    #: True when each row's value depends only on that row and the instance (not on the
    #: call's other rows nor earlier calls): a job may then gather its runs' batches into one
    #: call, records bit-identical. Default False (a noisy objective must not say so).
    rows_independent: ClassVar[bool] = False

    #: True when the objective fits a model to a record: without a truth, its best vector
    #: gets intervals, a profile and fit diagnostics. False for no fit (a test function
    #: offered without a truth); records then say ``problem.info.fits_a_record: false``.
    fits_a_record: ClassVar[bool] = True

    #: The named suites this problem belongs to: ``vpid-bench -m suite=<name>`` sweeps every
    #: registered problem whose class lists ``<name>`` here (with each one's defaults).
    suites: ClassVar[tuple[str, ...]] = ()

    #: The model family, for the report's aggregation over a suite (one ECDF and score per
    #: family, e.g. ``"quarter car"``); ``""``: the problem's own name stands for it.
    family: ClassVar[str] = ""

    def evaluate_instances(self, X: np.ndarray, instance: np.ndarray) -> np.ndarray:
        """Objective values ``(n,)`` of the rows of ``X``, row ``j`` against instance
        ``instance[j]`` (the gathered call of runs in lockstep): each must equal
        ``self.instance(instance[j]).evaluate(X[j:j+1])``. The default calls each distinct
        instance's ``evaluate`` once (instances kept: :func:`kept_instance`); override it to
        evaluate every row in one go."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        instance = np.asarray(instance, dtype=np.int64).reshape(-1)
        if instance.shape != (X.shape[0],):
            raise ValueError(f"evaluate_instances: {instance.shape[0]} instance indices for "
                             f"{X.shape[0]} rows")
        groups: dict[int, tuple[Problem, list[int]]] = {}
        for i in np.unique(instance):
            inst = kept_instance(self, int(i))
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
        """Extra facts (JSON-able) for every run record's ``problem.info``; the report reads
        ``f_at_true`` (a reference line) and ``metric_units`` (``{"rms_error": "%"}``)."""
        return {}

    def write_artifacts(self, directory: Path) -> list[Path]:
        """Write files a job should keep beside its records (e.g. the fitted reference)."""
        return []

    def content_digest(self) -> str | None:
        """A digest of the data this problem reads beyond its config (e.g. a record file's
        SHA-256), or ``None``: in every run id, so edited data runs again on resume."""
        return None

    def set_threads(self, n: int) -> None:
        """How many threads ``evaluate`` may use (``threads``); no result may depend on it."""
        return None


def kept_instance(problem: Problem, index: int) -> Problem:
    """``problem.instance(index)``, built once per problem object and kept (up to
    :data:`KEPT_INSTANCES`): every place the framework needs an instance goes through here.
    An instance is a pure function of config and index, so keeping it changes no result;
    building one can cost 0.5 s, and a job once built each about eight times."""
    kept = problem.__dict__.setdefault("_vpid_bench_instances", {})
    if index not in kept:
        if len(kept) >= KEPT_INSTANCES:
            kept.clear()
        kept[index] = problem.instance(index)
    return kept[index]


def offers_residuals(problem: Problem | type[Problem]) -> bool:
    """Whether a problem (an instance or its class) implements :meth:`Problem.residuals`."""
    cls = problem if isinstance(problem, type) else type(problem)
    return getattr(cls, "residuals", None) is not Problem.residuals
