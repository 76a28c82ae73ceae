"""``problem=fmu``: the parameters of any FMU (FMI 2.0 or 3.0, co-simulation or model
exchange) identified from a record it should reproduce; no truth. The keys, the start, the
input handling between samples and the refusals: docs/fmu.md. Checking a config reads the zip
and its description only (:mod:`.archive`); the binary is loaded where the problem evaluates
(a supervised worker, :mod:`.binary`).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import logging
from pathlib import Path
from typing import Any

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
)

from . import archive, plan, record

log = logging.getLogger(__name__)
OBJECTIVES = ("eq3", "ols")


@dataclasses.dataclass(frozen=True)
class ReferenceConfig:
    """``file``: the record (CSV); ``columns``: FMU names to record columns; ``ignore``: unused."""

    file: str | None = None
    columns: dict[str, str] = added_setting(default_factory=dict, open_keys=True)
    ignore: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        freeze_fields(self, "columns", prefix="problem.reference.")


@dataclasses.dataclass(frozen=True)
class FmuConfig(ProblemConfig):
    """The keys of ``problem=fmu`` (see the module docstring)."""

    fmu: str | None = None
    reference: ReferenceConfig = dataclasses.field(default_factory=ReferenceConfig)
    parameters: tuple[str, ...] | None = None
    bounds: dict[str, Any] = added_setting(default_factory=dict, open_keys=True)
    known: dict[str, Any] = added_setting(default_factory=dict, open_keys=True)
    interface: str = "auto"
    inputs: str = "auto"
    substeps: int = 10
    rtol: float = 1e-6
    atol: float = 1e-9
    objective: str = "eq3"

    def __post_init__(self) -> None:
        freeze_fields(self, "bounds", "known")
        checks = [
            ("interface", self.interface in ("auto", "cs", "me"), "one of auto, cs, me"),
            ("inputs", self.inputs in ("auto", "derivatives", "hold"),
             "one of auto, derivatives, hold"),
            ("substeps", 1 <= self.substeps <= 1000, "an integer in [1, 1000]"),
            ("rtol", 1e-12 <= self.rtol <= 1e-2, "a tolerance in [1e-12, 1e-2]"),
            ("atol", 0 < self.atol <= 1.0, "a tolerance in (0, 1]"),
            ("objective", self.objective in OBJECTIVES, "one of eq3, ols (the record states "
             "no noise level)"),
        ]
        for key, ok, allowed in checks:
            if not ok:
                raise ConfigError(f"problem.{key}", getattr(self, key), allowed)
        if self.fmu is None:
            raise ConfigError("problem.fmu", None, "the path of an FMU file (.fmu)")
        if self.reference.file is None:
            raise ConfigError("problem.reference.file", None, "the path of the record (CSV) "
                              "the FMU is fitted to (docs/fmu.md)")
        setup(self)  # the pre-flight reads the FMU and the record


def _mode(config: FmuConfig, fmu: archive.FmuFile, kind: str) -> tuple[str, str]:
    """The input handling and its one info line."""
    if kind == "me":
        if config.inputs not in ("auto",):
            raise ConfigError("problem.inputs", config.inputs, "auto for model exchange (its "
                              "inputs are linear between samples at any time)")
        return "linear", (f"model exchange: integrated by Dormand-Prince 5(4), rtol "
                          f"{config.rtol:g}, atol {config.atol:g}, the inputs linear between "
                          "samples")
    can = (fmu.major == 2 and bool(fmu.description.coSimulation.canInterpolateInputs))
    if config.inputs == "derivatives" and not can:
        raise ConfigError("problem.inputs", config.inputs, "hold or auto: this FMU cannot "
                          "interpolate inputs (FMI 2.0 canInterpolateInputs is not true)")
    if config.inputs == "derivatives" or (config.inputs == "auto" and can):
        return "derivatives", ("co-simulation: each input's slope over a step given to the "
                               "FMU (it can interpolate inputs), so it sees the record's "
                               "input linear between samples")
    why = ("as asked (problem.inputs=hold)" if config.inputs == "hold" else
           "FMI 3.0 has no input derivatives" if fmu.major == 3 else
           "the FMU cannot interpolate inputs")
    return "hold", (f"co-simulation: {config.substeps} sub-steps per sample with the input "
                    f"held over each ({why})")


@functools.lru_cache(maxsize=16)
def _setup(config: FmuConfig, fmu_state: tuple, record_state: tuple) -> tuple:
    fmu = archive.inspect(config.fmu)
    kind = config.interface  # the interface simulated
    if kind == "auto":
        kind = "cs" if "cs" in fmu.binaries else "me"
    if kind not in fmu.binaries:
        raise ConfigError("problem.interface", config.interface, "an interface this FMU has "
                          f"a binary for: {', '.join(sorted(fmu.binaries))}")
    if kind == "me" and fmu.major == 3:
        raise ConfigError("problem.interface", config.interface, "cs for an FMI 3.0 FMU "
                          "(FMI 3.0 model exchange is not supported)")
    if kind == "me" and int(fmu.description.numberOfEventIndicators or 0) > 0:
        raise ConfigError("problem.interface", config.interface, "cs, or an FMU without event "
                          "indicators (model exchange with events is not supported)")
    p = plan.plan(fmu.description, config.parameters, config.bounds, config.known)
    rec = record.read(config.reference.file, [(v.name, v.unit) for v in p.inputs],
                      [(v.name, v.unit) for v in p.outputs], config.reference.columns,
                      config.reference.ignore)
    return (fmu, kind, p, rec, *_mode(config, fmu, kind))


def _state(path: str) -> tuple:
    p = Path(path).expanduser()
    st = p.stat() if p.is_file() else None
    return (str(p), st.st_size if st else -1, st.st_mtime_ns if st else -1)


def setup(config: FmuConfig) -> tuple:
    """``(fmu, kind, plan, record, mode, mode_info)`` of ``config`` (cached), or ConfigError."""
    return _setup(config, _state(config.fmu), _state(config.reference.file))


class FmuProblem(ChannelFit, Problem):
    """An FMU's parameters from a record (see the module docstring)."""

    Config = FmuConfig
    name = "fmu"
    family = "FMU"
    rows_independent = True

    def __init__(self, config: FmuConfig) -> None:
        super().__init__(config)
        self.fmu, self.kind, self.plan, self.record, self.mode, self.mode_info = setup(config)
        self.t = self.record.t
        self.measured = self.record.outputs
        self.scale = np.linalg.norm(self.measured, axis=1)
        self.weights = estimators.weights(config.objective, self.measured,
                                          1.0 / self.scale[:, None], None)
        self._bounds = Bounds(self.plan.lower, self.plan.upper,
                              tuple(v.name for v in self.plan.identified),
                              tuple(v.unit or "1" for v in self.plan.identified))
        by_name = {v.name: v for v in self.plan.outputs}
        self.channels = tuple((n, by_name[n].unit or "") for n in self.record.output_names)
        self._vr_out = np.array([by_name[n].vr for n in self.record.output_names],
                                dtype=np.uint32)
        self._vr_in = np.array([v.vr for v in self.plan.inputs], dtype=np.uint32)
        known_vr, known_values = self.plan.start_values()
        self._vr_set = np.concatenate([known_vr, [v.vr for v in self.plan.identified]]
                                      ).astype(np.uint32)
        self._known_values = known_values
        self._how = {"mode": self.mode, "substeps": config.substeps, "rtol": config.rtol,
                     "atol": config.atol,
                     "states": len(getattr(self.fmu.description, "derivatives", []) or [])}
        self._failures = 0
        log.info("fmu %s (FMI %s): %s; record %s: %d rows, t = %.9g ... %.9g s (%s)",
                 Path(self.fmu.path).name, self.fmu.version, self.mode_info,
                 Path(self.record.path).name, self.t.size, self.t[0], self.t[-1],
                 self.record.rate_text())

    def computed(self, X: np.ndarray) -> np.ndarray:
        """The compared outputs ``(n, p, N)``; NaN rows where the FMU fails (three are logged)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        out = np.full((X.shape[0], self.measured.shape[0], self.t.size), np.nan)
        from .binary import FmuRuntimeError, simulator

        try:
            sim = simulator(self.fmu, self.kind)
        except FmuRuntimeError as exc:
            raise ConfigError("problem.fmu", self.fmu.path, f"an FMU whose binary runs: "
                              f"{exc}") from None
        for i, x in enumerate(X):
            if not np.all(np.isfinite(x)):
                continue
            values = np.concatenate([self._known_values, x])
            y, why = sim.simulate(self._vr_set, values, self.t, self.record.inputs,
                                  self._vr_in, self._vr_out, self._how)
            if y is None:
                self._failures += 1
                if self._failures <= 3:
                    log.info("fmu: a simulation failed (%s) at %s", why,
                             np.array2string(x, precision=6))
                continue
            out[i] = y.T
        return out

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    def diagnostic_signals(self, x: np.ndarray) -> dict[str, Any]:
        """The measured outputs over their norms, their names, each input at the samples."""
        return {"measured": (self.measured / self.scale[:, None]).reshape(-1),
                "names": list(self.record.output_names),
                "inputs": {v.name: self.record.inputs[:, j].copy()
                           for j, v in enumerate(self.plan.inputs)}}

    def describe(self) -> dict[str, Any]:
        md = self.fmu.description
        cfg = self.config
        columns = (", ".join(self.record.columns[v.name] for v in self.plan.inputs)
                   or "(none: the FMU has no inputs)")
        return {
            "samples": int(self.t.size),
            "objective": {"unit": "1", "what": estimators.DESCRIPTION[cfg.objective]
                          + " of the compared outputs, each over its norm"
                          if cfg.objective == "eq3" else estimators.DESCRIPTION[cfg.objective]
                          + " of the outputs over the record's norm"},
            "known": self.plan.known_list(),
            "box": self.plan.box_list(),
            "input": f"the record's columns {columns}; {self.mode_info}",
            "fmu": {"file": Path(self.fmu.path).name, "fmi_version": self.fmu.version,
                    "model": str(md.modelName)[:80],
                    "generation_tool": str(md.generationTool or "")[:80],
                    "interface": {"cs": "co-simulation", "me": "model exchange"}[self.kind]},
            "record": {"source": "file", "file": str(cfg.reference.file),
                       "rows": int(self.t.size), "rate": self.record.rate_text(),
                       "columns": dict(self.record.columns)},
            "fitted_model": {"inputs": self.mode, "info": self.mode_info,
                             **({"solver": "Dormand-Prince 5(4)", "rtol": cfg.rtol,
                                 "atol": cfg.atol} if self.kind == "me" else
                                {"substeps": cfg.substeps} if self.mode == "hold" else {})},
        }

    def content_digest(self) -> str | None:
        """The SHA-256 of the FMU and of the record: an edited file runs again on resume."""
        h = hashlib.sha256()
        for path in (self.fmu.path, self.config.reference.file):
            h.update(Path(path).expanduser().read_bytes())
        return h.hexdigest()
