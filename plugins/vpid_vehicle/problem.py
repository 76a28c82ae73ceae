"""``problem=vehicle``: the 9 unknowns of Eq. (4) from two body accelerations (docs/vehicle.md).
The clean reference is simulated once; each instance adds its own noise record
(``noise.per_run``), so run ``i`` of every optimizer fits record ``i``; a measured record is
every instance's.
"""

from __future__ import annotations

import copy
import hashlib
import logging
from pathlib import Path
from typing import Any

import numpy as np

from vpid_bench import Bounds, ChannelFit, ConfigError, Problem, estimators, relative_errors_percent

from .config import (
    PARAM_NAMES,
    PARAM_UNITS,
    VehicleConfig,
    known_list,
    own_boxes,
    window,
)
from .model import KnownConstants, physical
from .objective import add_noise, noise_summary
from .record_file import Sampler
from .reference_io import read_measured, write_reference
from .road import Bump
from .simulator import Simulator

log = logging.getLogger(__name__)


class VehicleProblem(ChannelFit, Problem):
    """Half-car parameter identification (Gökdağ 2014); see docs/vehicle.md."""

    Config = VehicleConfig
    name = "vehicle"
    rows_independent = True  # the kernel's values never depend on the batch (tested)
    channels = (("z1''", "m/s²"), ("z2''", "m/s²"))

    def __init__(self, config: VehicleConfig) -> None:
        super().__init__(config)  # the config validated itself when it was built
        p = config.vehicle
        self.known = KnownConstants(L=p.L, kt1=p.kt1, kt2=p.kt2)
        self.bump = Bump.from_geometry(config.bump.V, config.bump.h, config.bump.w, p.L)
        self.T = window(config)
        self._x_true = np.array([getattr(p, n) for n in PARAM_NAMES], dtype=float)
        self._x_true.setflags(write=False)
        lower = config.bounds.lower_factor * self._x_true
        upper = config.bounds.upper_factor * self._x_true
        for name, (lo, hi) in own_boxes(config).items():
            j = PARAM_NAMES.index(name)
            lower[j], upper[j] = lo, hi
        self._bounds = Bounds(lower, upper, PARAM_NAMES, PARAM_UNITS)
        nm = config.newmark
        ref = config.reference
        #: How the model meets a measured record's times (None: a synthetic record, on the
        #: model's own grid).
        self.sampler: Sampler | None = None
        if ref.file is not None:
            record = read_measured(ref.file, ref.mapping())
            self.sampler = Sampler(record.t, config.dt)
            self.T = float(self.sampler.steps[-1])
            self.record_info = self.sampler.describe(record)
            log.info("%s", self.record_info)
        self.model = Simulator(self.known, self.bump, self.T, config.dt, config.integrator,
                               config.sampling, nm.gamma, nm.beta)
        self.t = self.model.t_out
        if ref.file is not None:
            self.reference_source = "file"
            self.reference_clean: np.ndarray | None = None
            self.t = record.t
            self.reference = record.outputs
            self._digest: str | None = hashlib.sha256(Path(ref.file).read_bytes()).hexdigest()
        else:
            self.reference_source = "synthetic"
            dt_ref = config.dt if ref.dt is None else ref.dt
            ref_sim = Simulator(
                self.known, self.bump, self.T, dt_ref,
                ref.integrator or config.integrator, ref.sampling or config.sampling,
                nm.gamma, nm.beta, stride=int(round(config.dt / dt_ref)),
            )
            clean = ref_sim(self._x_true[None])[0]
            if clean.shape[1] != self.t.size:  # pragma: no cover - guarded by validate()
                raise RuntimeError("reference and model grids differ")
            self.reference_clean = clean
            self.reference = self._noise_record(0)
            self._digest = None
        self.reference.setflags(write=False)
        self._index = 0
        #: Instances made so far, by index, shared with every instance (0 is this problem).
        self._instances: dict[int, VehicleProblem] = {0: self}

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    # -- instances: one noise record each ------------------------------------------------------
    @property
    def _instances_differ(self) -> bool:
        """True when instances have different records: synthetic, noisy, ``noise.per_run``."""
        nz = self.config.noise
        return self.reference_source == "synthetic" and nz.level > 0 and nz.per_run

    def _noise_record(self, index: int) -> np.ndarray:
        """The noisy record of instance ``index`` (see :class:`~.config.NoiseConfig`)."""
        nz = self.config.noise
        seed = (np.random.SeedSequence(nz.seed, spawn_key=(index,)) if nz.per_run
                else nz.seed)
        assert self.reference_clean is not None
        return add_noise(self.reference_clean, nz.level, nz.model, np.random.default_rng(seed))

    def instance(self, index: int) -> VehicleProblem:
        """Instance ``index`` (its own noise record when instances differ), made once and kept."""
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
            raise ValueError(f"an instance index is an integer >= 0, not {index!r}")
        if not self._instances_differ:
            return self._instances[0]
        index = int(index)
        if index not in self._instances:
            inst = copy.copy(self._instances[0])  # shares the simulator and this cache
            inst._index = index
            inst.reference = self._noise_record(index)
            inst.reference.setflags(write=False)
            inst.__dict__.pop("_f_true", None)
            inst.__dict__.pop("_weights", None)
            self._instances[index] = inst
        return self._instances[index]

    def instance_id(self) -> str | None:
        """``"noise.seed=<seed>/<index>"`` when instances have their own records, else ``None``."""
        if not self._instances_differ:
            return None
        return f"noise.seed={self.config.noise.seed}/{self._index}"

    def residual_sigma(self) -> np.ndarray | None:
        """The simulated noise's sigma (m/s^2) per entry of :meth:`fisher_residuals`, or None."""
        nz = self.config.noise
        if self.reference_clean is None or nz.level <= 0:
            return None
        return estimators.noise_sigma(self.reference_clean, nz.level, nz.model).reshape(-1)

    @property
    def measured(self) -> np.ndarray:
        return self.reference

    @property
    def weights(self) -> np.ndarray:
        """What a raw residual is multiplied by, ``(2, N)``: 1 for Eq. 3 (m/s^2)."""
        if "_weights" not in self.__dict__:
            nz, ref = self.config.noise, self.reference
            sigma = (estimators.plug_in_sigma(ref, nz.level, nz.model)
                     if self.config.objective == "ml" else None)
            self._weights = estimators.weights(self.config.objective, ref, np.ones((2, 1)),
                                               sigma)
        return self._weights

    def content_digest(self) -> str | None:
        """The SHA-256 of ``reference.file`` as read, or ``None`` (the config defines it)."""
        return self._digest

    @property
    def x_true(self) -> np.ndarray | None:
        """The configured vehicle; ``None`` for a measured record (the box's centre, no truth)."""
        return None if self.reference_source == "file" else self._x_true.copy()

    def set_threads(self, n: int) -> None:
        """Let the kernel spread a large batch over ``n`` threads (bit-identical results)."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ConfigError("threads", n, "an integer >= 1")
        self.model.set_threads(int(n))

    def responses(self, X: np.ndarray) -> np.ndarray:
        """z1'' and z2'' (m/s^2) ``(n, 2, N)``; NaN rows for non-physical candidates."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        out = np.full((X.shape[0], 2, self.t.size), np.nan)
        ok = physical(X, self.known)
        if np.any(ok):
            with np.errstate(all="ignore"):
                y = self.model(X[ok])
                out[ok] = y if self.sampler is None else self.sampler.at_record(y)
        return out

    computed = responses

    @property
    def _on_grid(self) -> bool:
        """True when the record's samples are the model's steps (the compiled Eq. 3 path)."""
        return self.sampler is None or self.sampler.identity

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        """The objective of every row of ``X``, ``inf`` where a simulation fails."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if self.config.objective != "eq3" or not self._on_grid:
            return self.evaluate_with_residuals(X)[0]
        try:
            return self.model.objective(X, self.reference)
        except (ValueError, FloatingPointError, ZeroDivisionError, np.linalg.LinAlgError):
            return np.full(X.shape[0], np.inf)

    def evaluate_instances(self, X: np.ndarray, instance: np.ndarray) -> np.ndarray:
        """Eq. (3) of row ``j`` against instance ``instance[j]``, in one kernel call if possible."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        instance = np.asarray(instance, dtype=np.int64).reshape(-1)
        numbers, index = np.unique(instance, return_inverse=True)
        insts = [self.instance(int(i)) for i in numbers]
        shared = all(getattr(inst, "model", None) is self.model for inst in insts)
        if self.config.objective != "eq3" or not shared or not self._on_grid:
            return super().evaluate_instances(X, instance)
        try:
            if len(insts) == 1:
                return self.model.objective(X, insts[0].reference)
            key = tuple(id(inst.reference) for inst in insts)
            cached = getattr(self, "_stacked_refs", None)
            if cached is None or cached[0] != key:
                cached = self._stacked_refs = (key, np.stack([i.reference for i in insts]), insts)
            refs = cached[1]
            return self.model.objective_rows(X, refs, index.reshape(-1))
        except (ValueError, FloatingPointError, ZeroDivisionError, np.linalg.LinAlgError):
            return super().evaluate_instances(X, instance)

    def fisher_residuals(self, X: np.ndarray) -> np.ndarray:
        """Measured minus computed (m/s^2), z1'' then z2'', whatever the objective."""
        R = self.reference[None] - self.responses(X)
        R[~np.all(np.isfinite(R), axis=(1, 2))] = np.inf
        return R.reshape(R.shape[0], -1)

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        """``{"NoRE": ...}`` (%); none for a measured record (no truth)."""
        if self.reference_source == "file":
            return {}
        return {"NoRE": nore(x, self._x_true)}

    def evaluate_with_residuals(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``f`` and :meth:`residuals` from one simulation; inf where a candidate fails."""
        f, R = super().evaluate_with_residuals(X)
        if self.config.objective == "eq3":
            f = f / float(np.linalg.norm(self.reference, axis=1).sum())
        return f, R

    def describe(self) -> dict[str, Any]:
        cfg, b, own = self.config, self.config.bounds, own_boxes(self.config)
        rear_in = max(0.0, min(self.bump.rear_off, self.T) - self.bump.rear_on)
        info: dict[str, Any] = {
            "samples": int(self.t.size),
            "window_s": float(self.T),
            "t_last_s": float(self.t[-1]),
            "dt_s": float(cfg.dt),
            "integrator": cfg.integrator,
            "sampling": cfg.sampling,
            "bump_edges_s": [float(e) for e in self.bump.edges],
            "rear_excited_s": float(rear_in),
            "reference": {"source": self.reference_source},
            "known": known_list(cfg),
            "box": [{"name": n, "lower": float(lo), "upper": float(hi), "unit": u,
                     "source": (f"set by you (problem.bounds.{n})" if n in own else
                                f"[{b.lower_factor:g}, {b.upper_factor:g}] x the configured "
                                "vehicle (problem.bounds.lower_factor, upper_factor)")}
                    for n, u, lo, hi in zip(PARAM_NAMES, PARAM_UNITS, self._bounds.lower,
                                            self._bounds.upper, strict=True)],
        }
        if self.reference_source != "file" and not hasattr(self, "_f_true"):
            # the objective at the truth: the floor noise (or a model mismatch) sets
            self._f_true = float(self.evaluate(self._x_true[None])[0])
        ref = cfg.reference
        if self.reference_source == "file":
            info["reference"].update(file=str(ref.file), info=self.record_info,
                                     t0_s=float(self.t[0]), on_model_steps=bool(
                                         self.sampler is not None and self.sampler.on_steps))
            info["noise"] = {"applied": False}
        else:
            info.update(f_at_true=self._f_true, metric_units={"NoRE": "%"})
            info["reference"].update(
                integrator=ref.integrator or cfg.integrator,
                dt_s=float(ref.dt or cfg.dt),
                sampling=ref.sampling or cfg.sampling,
            )
            info["noise"] = {
                "applied": cfg.noise.level > 0,
                "model": cfg.noise.model,
                "level": cfg.noise.level,
                "seed": cfg.noise.seed,
                "per_run": cfg.noise.per_run,
                "record": self.instance_id(),
                **noise_summary(self.reference_clean, self.reference),
            }
        return info

    def write_artifacts(self, directory: Path) -> list[Path]:
        """``reference.csv``: this problem's clean and noisy record (a job's: instance 0)."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        path = write_reference(directory / "reference.csv", self.t, self.reference,
                               self.reference_clean)
        return [path]


def nore(x: np.ndarray, x_true: np.ndarray) -> float:
    """The paper's NoRE: the norm of ``100 (x - x_true) / x_true`` (%)."""
    return float(np.linalg.norm(relative_errors_percent(x, x_true)))
