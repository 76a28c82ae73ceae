"""What every ride problem of the suite shares: the record, its noise, the instances, the
objective and the residuals; a model adds only its matrices (docs/suite.md). The record is the
true vehicle's by the exact first-order hold at ``dt / record_substeps`` (``record=newmark``:
the fitted model's, an inverse crime on purpose), with additive Gaussian noise per channel;
instance ``i`` (run ``i``'s) draws its truth, random roads and noise from
``SeedSequence([seed, INSTANCE_ROOT, crc32(name)], spawn_key=(i,))``, never an optimizer's
stream. Objective: Eq. 3 by default or another estimator; metric: NoRE (%).
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import types
import zlib
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np

from vpid_bench import (
    Bounds,
    ChannelFit,
    ConfigError,
    Problem,
    ProblemConfig,
    added_setting,
    estimators,
    freeze_fields,
    relative_errors_percent,
)

from .. import knowns
from ..record_file import (
    Column,
    ColumnMap,
    Record,
    Sampler,
    check_span,
    column_name,
    read_record,
)
from . import roads
from .model import RideModel

log = logging.getLogger(__name__)
#: Most model steps of one record (a simulated one's ``duration_s / dt``, a user's span).
MAX_STEPS = 200_000

#: Mixed into the instances' seed so the data's streams never equal an optimizer's
#: (``SeedSequence(seed, spawn_key=(i,))``) at equal seeds.
INSTANCE_ROOT = 0x5EED1


#: Kept free of random truths at each side of the box, as a fraction of its width: the
#: determined members' optima lie within 0.5-6 % of the width from the truth in 9 runs of 10
#: (archive/smoke before round four), so they stay in the box.
TRUTH_MARGIN = 0.05


def instance_streams(seed: int, index: int, name: str) -> list[np.random.SeedSequence]:
    """The truth's, road's and noise's streams of instance ``index`` of problem ``name``."""
    root = [seed, INSTANCE_ROOT, zlib.crc32(name.encode("utf-8"))]  # stable per problem name
    return np.random.SeedSequence(root, spawn_key=(index,)).spawn(3)


def draw_truth(lower: np.ndarray, upper: np.ndarray, margin: float,
               rng: np.random.Generator) -> np.ndarray:
    """A truth uniform over the box less ``margin`` of its width at each side."""
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    width = upper - lower
    return lower + width * rng.uniform(margin, 1.0 - margin, lower.size)


def _check(checks: list[tuple[str, bool, str]], config: Any) -> None:
    """Raise :class:`ConfigError` for the first failed ``(key, ok, allowed)``."""
    for key, ok, allowed in checks:
        if not ok:
            raise ConfigError(f"problem.{key}", getattr(config, key), allowed)


@dataclasses.dataclass(frozen=True)
class RecordFileConfig:
    """``file``: one's own vehicle's record fitted instead (docs/own-record.md; no truth, no
    noise added). ``columns``: the problem's names mapped to the record's; ``ignore``: columns
    unused on purpose; ``input``: ``record`` or ``config`` (the configured road, manoeuvre)."""

    file: str | None = None
    columns: dict[str, str] = added_setting(default_factory=dict, open_keys=True)
    ignore: tuple[str, ...] = added_setting(default=())
    input: str = added_setting(default="record")

    def __post_init__(self) -> None:
        freeze_fields(self, "columns", prefix="problem.reference.")

    def mapping(self) -> ColumnMap:
        """The record reader's view of the mapping keys."""
        return ColumnMap(dict(self.columns), tuple(self.ignore))


@dataclasses.dataclass(frozen=True)
class SuiteConfig(ProblemConfig):
    """Keys every problem of the suite shares (docs/suite.md; a model's Config adds
    ``parameter_set``, ``sensors`` and its input); ``noise_level``: a fraction of each clean
    channel's rms."""

    duration_s: float = 3.0
    dt: float = 0.001
    noise_level: float = 0.05
    seed: int = 0
    truth: str = "random"
    truth_margin: float = TRUTH_MARGIN
    record: str = "exact"
    record_substeps: int = 10
    objective: str = "eq3"
    #: The model whose stated quantities and user's record are checked at the pre-flight.
    Model: ClassVar[type[RideModel] | None] = None
    reference: RecordFileConfig = added_setting(default_factory=RecordFileConfig)
    #: Stated quantities and boxes (:mod:`..knowns`): ``known.kt=210000``, ``known.ms=250``
    #: (fixed), ``known.kt=free``; ``bounds.ks=[lo, hi]``.
    known: dict[str, Any] = added_setting(default_factory=dict, open_keys=True)
    bounds: dict[str, Any] = added_setting(default_factory=dict, open_keys=True)

    def __post_init__(self) -> None:
        freeze_fields(self, "known", "bounds")
        # a user's record states no noise level (noise_level is what simulated records add)
        estimators.check_objective(self.objective, self.noise_level
                                   if self.reference.file is None else None)
        _check([
            ("truth", self.truth in ("random", "set"), "one of random, set"),
            ("record", self.record in ("exact", "newmark"), "one of exact, newmark"),
            ("duration_s", 0 < self.duration_s <= 60, "a duration in (0, 60] s"),
            ("dt", 1e-5 <= self.dt <= 0.01, "a sampling step in [1e-5, 0.01] s"),
            ("noise_level", 0 <= self.noise_level <= 1, "a fraction in [0, 1]"),
            ("truth_margin", 0 <= self.truth_margin < 0.5,
             "a fraction of the box's width in [0, 0.5)"),
            ("record_substeps", 1 <= self.record_substeps <= 100, "an integer in [1, 100]"),
        ], self)
        if self.duration_s / self.dt > MAX_STEPS:
            raise ConfigError("problem.duration_s", self.duration_s,
                              "at most 200000 samples (duration_s / dt)")
        self._check_own()
        if self.Model is not None:
            model = self.Model()
            knowns.check_config(self, model)
            if self.reference.file is not None:
                read_ride_record(model, self)

    def _check_own(self) -> None:
        """A family's own keys, checked before a user's record is read."""


@dataclasses.dataclass(frozen=True)
class RideConfig(SuiteConfig):
    """The road (:mod:`.roads`) at ``speed_kmh``; the suspension structure (:mod:`.structures`)."""

    road: str = "hump"
    road_class: str = "C"
    speed_kmh: float = 30.0
    spring: Literal["linear", "cubic"] = added_setting("linear")
    damper: Literal["linear", "bilinear"] = added_setting("linear")

    def _check_own(self) -> None:
        _check([
            ("road", self.road in ("hump", "bump", "step", "iso8608"),
             "one of hump, bump, step, iso8608"),
            ("road_class", self.road_class in roads.ISO8608_GD0, "one of A, B, ..., H"),
            ("speed_kmh", 0 < self.speed_kmh <= 200, "a speed in (0, 200] km/h"),
            ("spring", self.spring in ("linear", "cubic"), "one of linear, cubic"),
            ("damper", self.damper in ("linear", "bilinear"), "one of linear, bilinear"),
        ], self)
        if (self.spring, self.damper) != ("linear", "linear"):  # the structure makes its record
            _check([("record_model", getattr(self, "record_model", "linear") == "linear",
                     "linear when problem.spring or problem.damper is not linear (a richer "
                     "structure's record is its own)")], self)


def read_ride_record(model: RideModel, config: Any) -> Record:
    """A user's record for ``model`` (``zs''`` is column ``zsdd``), or a ConfigError."""
    channels = tuple(Column(column_name(c), unit, (c,)) for c, unit in
                     model.sensors[config.sensors])
    record = read_record(config.reference.file, channels, model.record_columns(),
                         model.needs_record_inputs(config), config.reference.mapping(),
                         input_mode=config.reference.input)
    model.check_record(record)
    check_span(record, config.dt, MAX_STEPS)
    return record


class RideProblem(ChannelFit, Problem):
    """A ride model identified from a road record (see the module docstring)."""

    model: ClassVar[RideModel]
    rows_independent = True

    def __init__(self, config: RideConfig, index: int = 0) -> None:
        from .structures import StructuredModel

        self.config = config
        self._index = index
        #: The model in the configured structure, with what the user fixed or freed (knowns.py).
        structure = (getattr(config, "spring", "linear"), getattr(config, "damper", "linear"))
        if structure != ("linear", "linear"):
            self.model = StructuredModel(self.model, *structure)
        if config.known or config.bounds:
            self.model = knowns.StatedModel(self.model, knowns.plan(config, self.model,
                                                                    type(self).name))
        published = self.model.sets[config.parameter_set]
        self.nominal = np.array([published[k] for k in self.model.names])
        self.known = {k: v for k, v in published.items() if k not in self.model.names}
        #: How the model meets a user's record (None: the simulated record, on its grid).
        self.sampler: Sampler | None = None
        if config.reference.file is not None:  # no truth, no noise added, at rest at row one
            record = read_ride_record(self.model, config)
            self.sampler = sampler = Sampler(record.t, config.dt)
            self.input_source = knowns.input_text(config, record.input_names,
                                                  config.reference.columns)
            if record.inputs is not None:
                self.u = self.model.inputs_from_record(record, sampler)
            else:  # the configured input (a hump, a bump, a step, a manoeuvre) over the steps
                span = types.SimpleNamespace(**vars(config))
                span.duration_s = sampler.steps.size * config.dt
                self.u = self.model.inputs(span, self.known, config.dt, None)
            self.record_info = sampler.describe(record)
            log.info("%s", self.record_info)
            self._x_true = None
            self.t = record.t
            self.clean = None
            self.sigma = None
            self.measured = record.outputs
        else:
            streams = instance_streams(config.seed, index, type(self).name)
            truth_rng, road_rng, noise_rng = (np.random.default_rng(s) for s in streams)
            self._x_true = (draw_truth(*self.model.box(self.nominal), config.truth_margin,
                                       truth_rng) if config.truth == "random"
                            else self.nominal.copy())
            sub = config.record_substeps if config.record == "exact" else 1
            fine = self.model.inputs(config, self.known, config.dt / sub, road_rng)
            self.u = fine[::sub].copy()  # a view would keep the fine input (10x larger) alive
            self.t = np.arange(self.u.shape[0]) * config.dt
            self.clean = self._record(fine, sub)
            self.sigma = config.noise_level * np.sqrt(np.mean(self.clean**2, axis=1))
            self.measured = self.clean + self.sigma[:, None] * noise_rng.standard_normal(
                self.clean.shape)
        self.scale = np.linalg.norm(self.measured, axis=1)
        if np.any(self.scale <= 0):
            if self.sampler is None:
                raise ConfigError("problem.duration_s", config.duration_s, "a record in "
                                  "which every measured channel moves (one is zero throughout)")
            c = self.channels[int(np.flatnonzero(self.scale <= 0)[0])][0]
            raise ConfigError("problem.reference.file", config.reference.file,
                              f"a record in which every measured channel moves (column "
                              f"{column_name(c)} is zero throughout)")
        # ml is refused for a user's record (no stated noise): no plug-in sigma there
        plug_in = (estimators.plug_in_sigma(self.measured, config.noise_level, "additive")
                   if config.objective == "ml" else None)
        #: What a raw residual is multiplied by, ``(p, N)`` (Eq. 3: ``1 / ||measured_c||``).
        self.weights = estimators.weights(config.objective, self.measured,
                                          1.0 / self.scale[:, None], plug_in)

    def _record(self, fine_u: np.ndarray, sub: int) -> np.ndarray:
        """The true vehicle's clean channels ``(p, N)`` sampled every ``dt``."""
        dt = self.config.dt / sub
        y = self.model.simulate(self._x_true[None], self.known, self.config.sensors, fine_u, dt,
                                self.config.record)
        return y[0, ::sub].T

    @property
    def channels(self) -> tuple[tuple[str, str], ...]:
        return self.model.sensors[self.config.sensors]

    # --- core ---------------------------------------------------------------------------
    @property
    def bounds(self) -> Bounds:
        lower, upper = self.model.box(self.nominal)
        return Bounds(lower, upper, self.model.names, self.model.units)

    @property
    def x_true(self) -> np.ndarray | None:
        """The instance's truth; ``None`` for a user's record (no truth)."""
        return None if self._x_true is None else self._x_true.copy()

    def responses(self, X: np.ndarray) -> np.ndarray:
        """The fitted model's channels ``(n, p, N)``; NaN rows for a row that is no vehicle."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        out = np.full((X.shape[0], self.measured.shape[0], self.t.size), np.nan)
        ok = self.model.physical(X, self.known)
        if np.any(ok):
            with np.errstate(all="ignore"):
                y = self.model.simulate(X[ok], self.known, self.config.sensors, self.u,
                                        self.config.dt, "newmark").transpose(0, 2, 1)
                out[ok] = y if self.sampler is None else self.sampler.at_record(y)
        return out

    computed = responses

    def residual_sigma(self) -> np.ndarray | None:
        """The simulated noise's sigma per channel of :meth:`fisher_residuals`, or ``None``."""
        if self.config.noise_level <= 0 or self.sigma is None:
            return None
        return self.sigma / self.scale

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        """``{"NoRE": ...}`` (%) against this instance's truth; none for a user's record."""
        if self._x_true is None:
            return {}
        return {"NoRE": float(np.linalg.norm(relative_errors_percent(x, self._x_true)))}

    def content_digest(self) -> str | None:
        """The SHA-256 of a user's record (an edited record runs again on resume), else ``None``."""
        if self.sampler is None:
            return None
        return hashlib.sha256(Path(self.config.reference.file).read_bytes()).hexdigest()

    # --- instances ----------------------------------------------------------------------
    def instance(self, index: int) -> RideProblem:
        """Instance ``index``; a user's record is every instance's."""
        if index == self._index or self.sampler is not None:
            return self
        return type(self)(self.config, index)

    def instance_id(self) -> str | None:
        return None if self.sampler is not None else f"seed={self.config.seed}/{self._index}"

    # --- signals ------------------------------------------------------------------------
    def diagnostic_signals(self, x: np.ndarray) -> dict[str, Any]:
        """The measured channels over their norms, their names and the model's inputs."""
        u = np.asarray(self.u, dtype=float)
        u = u.T if self.sampler is None else self.sampler.at_record(u.T[None])[0]
        wheels = self.model.wheel_names
        names = ([n for w in wheels for n in (w, f"{w}'")] if u.shape[0] == 2 * len(wheels)
                 else [f"u{j}" for j in range(u.shape[0])])
        return {"measured": (self.measured / self.scale[:, None]).reshape(-1),
                "names": [name for name, _ in self.channels],
                "inputs": {n: u[j] for j, n in enumerate(names)
                           if u.shape[1] == self.t.size}}

    def describe(self) -> dict[str, Any]:
        cfg = self.config
        # the fitted model's solver in words (a richer structure's: :mod:`.structures`)
        solver = getattr(self.model, "fitted_solver", "Newmark average acceleration")
        info = {"samples": int(self.t.size), **knowns.info(self),
                "fitted_model": {"solver": solver, "dt_s": cfg.dt}}
        if self.sampler is not None:
            info["record"] = {"source": "file", "file": str(cfg.reference.file),
                              "info": self.record_info}
            return info
        exact = cfg.record == "exact"
        info.update({
            "record": {"solver": "exact first-order hold" if exact
                       else "Newmark (the fitted model: inverse crime)",
                       "dt_s": cfg.dt / (cfg.record_substeps if exact else 1)},
            "noise": {"model": "additive Gaussian", "sigma": self.sigma.tolist(),
                      "channels": [c for c, _ in self.channels]},
            "truth": self._x_true.tolist(),
            "f_at_true": float(self.evaluate(self._x_true[None])[0]),
            "metric_units": {"NoRE": "%"},
        })
        richer = getattr(cfg, "record_model", "linear")
        if richer != "linear":  # the report explains a floor below the bound by it
            from .richer import DESCRIPTIONS, FIT_WITH

            info["model_error"] = {"record_model": richer, "what": DESCRIPTIONS[richer],
                                   "fit_with": FIT_WITH[richer]}
        return info
