"""Settings of ``problem=vehicle`` and their validation (one :class:`ConfigError` line naming
the key, before any simulation). Units SI except the bump speed ``V`` (km/h, as in the
paper); defaults: the paper's vehicle and test (Gökdağ 2014, docs/paper-notes.md).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from vpid_bench import ConfigError, ProblemConfig, added_setting, estimators, freeze_fields

#: The unknowns of Eq. (4), in order, with their units.
PARAM_NAMES: tuple[str, ...] = ("m", "I", "m1", "m2", "k1", "k2", "c1", "c2", "a1")
PARAM_UNITS: tuple[str, ...] = ("kg", "kg m^2", "kg", "kg", "N/m", "N/m", "N s/m", "N s/m", "m")

INTEGRATORS = ("newmark", "exact")

#: Caps that keep a typo from asking for hours or gigabytes (docs/sweeps.md lists them).
#: Samples of one simulated record: the model's grid, and the synthetic reference's finer grid.
MAX_SAMPLES = 1_000_000
#: Largest estimated memory of one job's simulations (bytes).
MAX_MEMORY = 2 * 1024**3
#: Bytes per simulated time step (the road input, the kernel's state and set-up) and per
#: sample and candidate of a batch (the responses and residuals of the residual path);
#: measured with tracemalloc by benchmarks/memory_per_sample.py: about 112 and 35.
BYTES_PER_STEP = 128
BYTES_PER_SAMPLE_CANDIDATE = 40
#: Largest bump height |h| in m (the paper's is 0.04 m).
MAX_BUMP_HEIGHT = 1.0
SAMPLINGS = ("point", "average")
NOISE_MODELS = ("multiplicative", "additive", "uniform")


@dataclass(frozen=True)
class VehicleParams:
    """The half car (kg, kg m^2, N/m, N s/m, m): ``a1`` from the centre of gravity to the
    front axle; the wheelbase ``L`` and tyre stiffnesses ``kt1``, ``kt2`` are known."""

    m: float = 505.1
    I: float = 651.0
    m1: float = 28.58
    m2: float = 54.3
    k1: float = 15000.0
    k2: float = 15000.0
    c1: float = 1828.0
    c2: float = 1828.0
    a1: float = 1.468
    L: float = 2.566
    kt1: float = 155900.0
    kt2: float = 155900.0


@dataclass(frozen=True)
class BumpConfig:
    """Rectangular bump: speed ``V`` (km/h, the paper's unit), height ``h``, width ``w`` (m)."""

    V: float = 20.0
    h: float = 0.04
    w: float = 0.10


@dataclass(frozen=True)
class NewmarkConfig:
    """Newmark-beta (default average acceleration): ``gamma`` in [0.5, 1], ``beta`` in [0, 0.5]."""

    gamma: float = 0.5
    beta: float = 0.25


@dataclass(frozen=True)
class RecordConfig:
    """``extra``: seconds recorded after the paper's window ``(L + w) / V`` ends (>= 0)."""

    extra: float = 0.0


@dataclass(frozen=True)
class NoiseConfig:
    """Noise added to the synthetic reference (:func:`.objective.add_noise`; ``multiplicative``
    is the default reading of the paper's "5 %"); ``seed`` seeds the noise only.
    ``per_run``: instance ``i`` (run ``i`` of every optimizer) gets its own record from
    ``SeedSequence(seed, spawn_key=(i,))``; false: one record from ``default_rng(seed)``."""

    level: float = 0.05
    model: str = "multiplicative"
    seed: int = 0
    per_run: bool = True


@dataclass(frozen=True)
class ReferenceConfig:
    """How the reference is made (``null``: as the model). ``integrator``, ``dt`` (s,
    dividing ``problem.dt``), ``sampling``: a synthetic reference unlike the fitted model (no
    inverse crime). ``file``: a measured record (:mod:`.reference_io`) fitted instead, no
    noise added, no truth."""

    integrator: str | None = None
    dt: float | None = None
    sampling: str | None = None
    file: str | None = None
    #: The problem's names mapped to the record's columns, and record columns left unused on
    #: purpose (docs/own-record.md); the input is the bump, part of the problem's design.
    columns: dict[str, str] = added_setting(default_factory=dict, open_keys=True)
    ignore: tuple[str, ...] = added_setting(default=())

    def __post_init__(self) -> None:
        freeze_fields(self, "columns", prefix="problem.reference.")

    def mapping(self) -> Any:
        """The record reader's view of the mapping keys."""
        from .record_file import ColumnMap

        return ColumnMap(dict(self.columns), tuple(self.ignore))


@dataclass(frozen=True)
class BoundsConfig:
    """The box ``[lower_factor, upper_factor] x`` the truth; ``bounds.<name>=[lo,hi]`` (SI)."""

    lower_factor: float = 0.5
    upper_factor: float = 1.5
    m: tuple[float, ...] | None = added_setting(None)
    I: tuple[float, ...] | None = added_setting(None)  # noqa: E741 - the paper's name
    m1: tuple[float, ...] | None = added_setting(None)
    m2: tuple[float, ...] | None = added_setting(None)
    k1: tuple[float, ...] | None = added_setting(None)
    k2: tuple[float, ...] | None = added_setting(None)
    c1: tuple[float, ...] | None = added_setting(None)
    c2: tuple[float, ...] | None = added_setting(None)
    a1: tuple[float, ...] | None = added_setting(None)


#: ``problem.known.<name>`` of ``problem=vehicle``: the part whose key ``<name>`` it sets,
#: its unit and what it is.
KNOWN = {"L": ("vehicle", "m", "wheelbase"), "kt1": ("vehicle", "N/m", "front tyre stiffness"),
         "kt2": ("vehicle", "N/m", "rear tyre stiffness"), "V": ("bump", "km/h", "bump speed"),
         "h": ("bump", "m", "bump height"), "w": ("bump", "m", "bump width")}


@dataclass(frozen=True)
class VehicleConfig(ProblemConfig):
    """``problem=vehicle``: 9 parameters of a half car from two body accelerations (keys:
    docs/vehicle.md). ``dt``: step and sample interval (s); ``integrator``: ``newmark`` or
    ``exact``; ``sampling``: :mod:`vpid_vehicle.road`; ``objective``: ``eq3`` (the paper's),
    ``ols``, ``ml`` (the stated noise; refused for a measured record) or ``ml_profiled``."""

    vehicle: VehicleParams = field(default_factory=VehicleParams)
    bump: BumpConfig = field(default_factory=BumpConfig)
    dt: float = 0.001
    integrator: str = "newmark"
    sampling: str = "point"
    newmark: NewmarkConfig = field(default_factory=NewmarkConfig)
    record: RecordConfig = field(default_factory=RecordConfig)
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    reference: ReferenceConfig = field(default_factory=ReferenceConfig)
    bounds: BoundsConfig = field(default_factory=BoundsConfig,
                                 metadata={"vpid_bench_open_keys": True})
    objective: str = "eq3"
    #: Stated quantities by name (``known.kt1=170000``): each sets its ``vehicle.`` or
    #: ``bump.`` key (:data:`KNOWN`).
    known: dict[str, Any] = added_setting(default_factory=dict, open_keys=True)

    def __post_init__(self) -> None:
        freeze_fields(self, "known")
        # each known.<name> sets its vehicle. or bump. key (a fixed set: nothing freed)
        for name, value in self.known.items():
            key = f"problem.known.{name}"
            if name not in KNOWN:
                raise ConfigError(key, value, "one of " + ", ".join(KNOWN) + " (the "
                                  "stated quantities of problem=vehicle; fixing or freeing a "
                                  "parameter is offered by problem=ride_half, the same half car)")
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ConfigError(key, value, f"a number in {KNOWN[name][1]}")
            part = KNOWN[name][0]
            object.__setattr__(self, part, dataclasses.replace(getattr(self, part),
                                                               **{name: float(value)}))
        validate(self)  # at build time, so the pre-flight refuses a bad value before any job


def known_list(config: VehicleConfig) -> list[dict[str, Any]]:
    """``problem.info.known``: each stated quantity with its value, unit and source."""
    out = []
    for name, (part, unit, what) in KNOWN.items():
        value = getattr(getattr(config, part), name)
        default = getattr(type(getattr(config, part))(), name)
        source = (f"set by you (problem.known.{name})" if name in config.known else
                  f"set by you (problem.{part}.{name})" if value != default else
                  "the paper's vehicle and test (Gökdağ 2014)")
        out.append({"name": name, "value": float(value), "unit": unit, "source": source,
                    "what": what})
    return out


def own_boxes(config: VehicleConfig) -> dict[str, tuple[float, float]]:
    """The parameters' own boxes (``problem.bounds.<name>``), checked."""
    out = {}
    for name in PARAM_NAMES:
        value = getattr(config.bounds, name)
        if value is None:
            continue
        if len(value) != 2 or not all(math.isfinite(v) for v in value) \
                or not 0 < value[0] < value[1]:
            raise ConfigError(f"problem.bounds.{name}", list(value),
                              "[lo, hi] with 0 < lo < hi, finite (SI units)")
        if name == "a1" and value[1] >= config.vehicle.L:
            raise ConfigError("problem.bounds.a1", list(value),
                              f"[lo, hi] with hi < L = {config.vehicle.L:g} m")
        out[name] = (float(value[0]), float(value[1]))
    return out


def _require(key: str, value: Any, ok: bool, allowed: str) -> None:
    if not ok:
        raise ConfigError(key, value, allowed)


def _positive(key: str, value: float, allowed: str) -> None:
    _require(key, value, math.isfinite(value) and value > 0, allowed)


def _choice(key: str, value: str | None, choices: tuple[str, ...], nullable: bool = False) -> None:
    if value is None and nullable:
        return
    if value not in choices:
        allowed = "one of " + ", ".join(choices) + (" or null" if nullable else "")
        raise ConfigError(key, value, allowed)


def window(config: VehicleConfig) -> float:
    """The record length (s): the front tyre meets the bump until the rear one leaves, + extra."""
    v = config.bump.V / 3.6
    return (config.vehicle.L + config.bump.w) / v + config.record.extra


def validate(config: VehicleConfig) -> None:
    """Raise ConfigError for the first value that makes no physical or numerical sense."""
    _validate_vehicle(config)
    _validate_simulation(config)
    T = window(config)
    _require("problem.dt", config.dt, T >= config.dt,
             f"a step no longer than the window T = {T:g} s")
    _validate_noise_and_reference(config)
    # a measured record states no noise level (noise.level is what synthetic records add)
    estimators.check_objective(config.objective, config.noise.level
                               if config.reference.file is None else None)
    if config.reference.file is not None:  # read at the pre-flight: its span is the window
        from .record_file import check_span
        from .reference_io import read_measured

        record = read_measured(config.reference.file, config.reference.mapping())
        check_span(record, config.dt, MAX_SAMPLES)
        T = record.span
    check_size(config, T)
    _validate_bounds(config)


def _validate_vehicle(config: VehicleConfig) -> None:
    p = config.vehicle
    for name in ("m", "m1", "m2"):
        _positive(f"problem.vehicle.{name}", getattr(p, name), "a mass > 0 (kg)")
    _positive("problem.vehicle.I", p.I, "an inertia > 0 (kg m^2)")
    for name in ("k1", "k2", "kt1", "kt2"):
        _positive(f"problem.vehicle.{name}", getattr(p, name), "a stiffness > 0 (N/m)")
    for name in ("c1", "c2"):
        c = getattr(p, name)
        _require(f"problem.vehicle.{name}", c, math.isfinite(c) and c >= 0,
                 "a damping >= 0 (N s/m)")
    _positive("problem.vehicle.L", p.L, "a wheelbase > 0 (m)")
    _require("problem.vehicle.a1", p.a1, math.isfinite(p.a1) and 0.0 < p.a1 < p.L,
             f"a value in (0, L) = (0, {p.L:g}) m")
    _positive("problem.bump.V", config.bump.V, "a speed > 0 (km/h)")


def _validate_simulation(config: VehicleConfig) -> None:
    h = config.bump.h
    _require("problem.bump.h", h, math.isfinite(h) and 0 < abs(h) <= MAX_BUMP_HEIGHT,
             f"a bump height with 0 < |h| <= {MAX_BUMP_HEIGHT:g} m (0.04 in the paper; "
             "negative: a pothole)")
    _positive("problem.bump.w", config.bump.w, "a bump width > 0 (m)")
    _positive("problem.dt", config.dt, "a time step > 0 (s)")
    _choice("problem.integrator", config.integrator, INTEGRATORS)
    _choice("problem.sampling", config.sampling, SAMPLINGS)
    g, b, extra = config.newmark.gamma, config.newmark.beta, config.record.extra
    _require("problem.newmark.gamma", g, math.isfinite(g) and 0.5 <= g <= 1.0,
             "a value in [0.5, 1] (default 0.5)")
    _require("problem.newmark.beta", b, math.isfinite(b) and 0.0 <= b <= 0.5,
             "a value in [0, 0.5] (default 0.25)")
    _require("problem.record.extra", extra, math.isfinite(extra) and extra >= 0,
             "seconds >= 0 recorded after the window")


def _validate_noise_and_reference(config: VehicleConfig) -> None:
    nz = config.noise
    _require("problem.noise.level", nz.level, math.isfinite(nz.level) and nz.level >= 0,
             "a noise level >= 0 (0.05 = 5 %)")
    _choice("problem.noise.model", nz.model, NOISE_MODELS)
    _require("problem.noise.seed", nz.seed, nz.seed >= 0, "an integer >= 0")
    ref = config.reference
    _choice("problem.reference.integrator", ref.integrator, INTEGRATORS, nullable=True)
    _choice("problem.reference.sampling", ref.sampling, SAMPLINGS, nullable=True)
    if ref.dt is not None:
        _positive("problem.reference.dt", ref.dt, "a time step > 0 (s) or null")
        ratio = config.dt / ref.dt
        _require("problem.reference.dt", ref.dt,
                 abs(ratio - round(ratio)) <= 1e-6 * ratio and round(ratio) >= 1,
                 f"null or a step dividing problem.dt = {config.dt:g} s (e.g. {config.dt / 10:g})")


def _validate_bounds(config: VehicleConfig) -> None:
    p, b = config.vehicle, config.bounds
    _positive("problem.bounds.lower_factor", b.lower_factor, "a factor > 0")
    _require("problem.bounds.upper_factor", b.upper_factor,
             math.isfinite(b.upper_factor) and b.upper_factor > b.lower_factor,
             f"a factor > problem.bounds.lower_factor = {b.lower_factor:g}")
    own_boxes(config)
    _require("problem.bounds.upper_factor", b.upper_factor,
             b.upper_factor * p.a1 < p.L or b.a1 is not None,
             f"a factor with upper_factor * a1 < L, i.e. < {p.L / p.a1:.4g} (a2 = L - a1 > 0)")


def _gib(n_bytes: float) -> str:
    return f"about {n_bytes / 1024**3:.3g} GiB"


def _blame(config: VehicleConfig, T: float) -> tuple[str, float]:
    """The key that made the record long: ``dt`` (against 1 ms), else the window's largest term."""
    if 0.001 / config.dt > T / 0.48:
        return "problem.dt", config.dt
    v = config.bump.V / 3.6
    terms = {"problem.bump.w": (config.bump.w / v, config.bump.w),
             "problem.record.extra": (config.record.extra, config.record.extra),
             "problem.bump.V": (config.vehicle.L / v, config.bump.V)}
    key = max(terms, key=lambda k: terms[k][0])
    return key, terms[key][1]


def check_size(config: VehicleConfig, T: float) -> None:
    """Refuse a record past :data:`MAX_SAMPLES` samples or a job past :data:`MAX_MEMORY`
    (estimated by :data:`BYTES_PER_STEP` and :data:`BYTES_PER_SAMPLE_CANDIDATE`: no array
    is made to count them), naming the key that made it large and the estimate."""
    samples = T / config.dt + 1
    ref_dt = config.reference.dt if config.reference.file is None else None
    steps = T / ref_dt + 1 if ref_dt else samples
    n_bytes = (samples + steps) * BYTES_PER_STEP + samples * config.ps * BYTES_PER_SAMPLE_CANDIDATE
    what = (f"this one: T = {T:.4g} s at problem.dt = {config.dt:g} s is {samples:.4g} samples, "
            f"{_gib(n_bytes)} for ps = {config.ps} candidates")
    if samples > MAX_SAMPLES:
        key, value = _blame(config, T)
        raise ConfigError(key, value, f"a record of at most {MAX_SAMPLES} samples ({what})")
    if steps > MAX_SAMPLES:
        raise ConfigError("problem.reference.dt", config.reference.dt,
                          f"a reference of at most {MAX_SAMPLES} steps (this one: T = {T:.4g} s "
                          f"at {config.reference.dt:g} s is {steps:.4g} steps, {_gib(n_bytes)})")
    if n_bytes > MAX_MEMORY:
        raise ConfigError("problem.ps", config.ps, f"a job of at most {_gib(MAX_MEMORY)} "
                          f"({what})")
