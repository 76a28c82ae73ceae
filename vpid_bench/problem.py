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
        relative error), else ``None``: a problem **without a truth** (a measured record).
        Then no error against any nominal value is computed anywhere; a problem with
        residuals gets each run's identified values with 95 % intervals (``result.intervals``
        of its record, from the Jacobian with σ estimated from the residuals per group) and
        profile-likelihood intervals at the record's optimum (:mod:`vpid_bench.analysis
        .estimates`), and the report ranks by :meth:`metrics` (held-out errors) or the
        objective and says the problem has no truth."""
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
        (:func:`vpid_bench.store.artifacts.write_best_signals`), which report sections plot.
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
        run of a context has it, else by the objective. Default: none.

        Without a truth these are what can be measured instead: errors on held-out data (a
        validation record: the simulation error as RMS, the fit in percent with the sign
        turned so that lower is better), the headline first."""
        return {}

    def comparisons(self) -> dict[str, dict[str, Any]]:
        """Named fixed comparison rows that are not runs and not truths, e.g.
        ``{"published estimate": {"x": [...], "note": "IDIM-LS, Janot et al."},
        "naive predictor": {"metrics": {"val_rms": 0.31}, "note": "each state held"}}``.
        A row with ``x`` (physical units) gets its objective and :meth:`metrics` computed by
        the framework (``metrics`` given in the row override them); a row without ``x``
        shows the metrics it gives. The report prints them beside the ranking, so a result
        can be judged against a published estimate or a predictor it must beat. Default:
        none."""
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

    def fisher_residuals(self, X: np.ndarray) -> np.ndarray:
        """Measured minus computed with weights that depend neither on the parameters nor
        on the objective, shape ``(n, m)``, in the units of :meth:`residual_sigma`: what the
        Fisher information (:mod:`vpid_bench.analysis.identifiability`) and the profile
        likelihood differentiate (the bound belongs to the data). It differs from
        :meth:`residuals` where an objective rescales its residuals by a function of the
        parameters (``ml_profiled``, :mod:`vpid_bench.estimators`). Default:
        :meth:`residuals`."""
        return self.residuals(X)

    def fisher_groups(self) -> np.ndarray:
        """The group (measured channel) of each entry of :meth:`fisher_residuals`, ``(m,)``
        ints: a ``σ`` given per group is per these groups, and the bounds' rounding rule and
        σ-floor sensitivity work per group. Default: :meth:`residual_groups`."""
        return self.residual_groups()

    def residual_sigma(self) -> np.ndarray | None:
        """The standard deviation of the measurement noise in each group of
        :meth:`fisher_groups` (units of :meth:`fisher_residuals`), shape ``(groups,)``, or of
        each entry, shape ``(m,)``
        (noise whose sigma varies along the record), for the Fisher information; ``None`` when
        it is not known (a measured record). It is the noise that was simulated, whatever the
        objective: the bound belongs to the data, not to the estimator."""
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

    #: True when the objective fits a model to a record (measured or simulated): without a
    #: truth, its best vector is an identified value with intervals, a profile and fit
    #: diagnostics. False for an objective that is no fit, e.g. a test function whose
    #: minimiser is offered as no truth: then none of those is computed, and the report says
    #: the problem gives no truth instead of calling it a measured record (round five's N16).
    #: The job writes ``problem.info.fits_a_record: false`` into its records then.
    fits_a_record: ClassVar[bool] = True

    #: The named suites this problem belongs to: ``vpid-bench -m suite=<name>`` sweeps every
    #: registered problem whose class lists ``<name>`` here (with each one's defaults).
    suites: ClassVar[tuple[str, ...]] = ()

    #: The model family, for the report's aggregation over a suite (one ECDF and score per
    #: family, e.g. ``"quarter car"``); ``""``: the problem's own name stands for it.
    family: ClassVar[str] = ""

    def evaluate_instances(self, X: np.ndarray, instance: np.ndarray) -> np.ndarray:
        """Objective values of the rows of ``X`` (shape ``(n, dim)``), row ``j`` against
        instance ``instance[j]`` (int array ``(n,)``), shape ``(n,)``: the gathered call of runs
        in lockstep. Must equal ``self.instance(instance[j]).evaluate(X[j:j+1])`` for each row.

        The default groups the rows by instance (instances that are the same object, e.g. the
        problem itself, form one group) and calls each group's ``evaluate`` once. Each
        instance is built once and kept (:func:`kept_instance`): this call comes once per step
        of the run loop, and a problem whose ``instance`` makes a record (the suite's ride
        problems solve it exactly) once spent most of a sweep rebuilding it. A problem
        whose instances share an expensive part overrides it to evaluate every row in one go.
        """
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


def kept_instance(problem: Problem, index: int) -> Problem:
    """``problem.instance(index)``, built once per problem object and kept (up to
    :data:`KEPT_INSTANCES`; past it the kept ones are dropped and built again).

    Every place the framework needs an instance goes through here: the run loop's gathered
    calls, the records, the optimum analysis, the floors, the stopping values. An instance is
    a pure function of the problem's config and its index, so keeping it changes no result;
    building it can be costly (the suite's ride problems solve their record exactly, 0.1 to
    0.5 s), and a job once built each instance about eight times, and every job of a sweep
    again (the jobs of one problem config share its problem object, :class:`~.build.ProblemCache`).
    """
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
