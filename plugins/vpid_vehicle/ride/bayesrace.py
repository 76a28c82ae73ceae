"""``problem=bayesrace``: a 1:43 race car's tyre, drive and yaw coefficients from records
somebody else's simulator made (Bayesrace, published with Deep Dynamics; GPL-3.0, read by
:mod:`.third_party`; its explicit Euler step at 50 Hz, no noise added), fitted by its equations
in continuous time (:func:`.kernel.dynamic_single_track`, SI units) by RK4 at ``20 ms /
substeps``. The equations, what is identified and known, the objective and the metrics:
docs/measured.md, "Bayesrace".
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar, Literal

import numpy as np

from vpid_bench import (
    Bounds,
    ChannelFit,
    ConfigError,
    Problem,
    ProblemConfig,
    estimators,
    relative_errors_percent,
)

from . import third_party

#: The rows of :func:`.kernel.dynamic_single_track`'s parameter block: each axle's Magic
#: Formula (``B, C, D, E``, the shifts ``Sh``, ``Sv``), the drive (``Cm1, Cm2``), the
#: resistance (``Cr0, Cr2``) and the yaw inertia.
DYNAMIC_ROWS = ("Bf", "Cf", "Df", "Ef", "Shf", "Svf", "Br", "Cr", "Dr", "Er", "Shr", "Svr",
                "Cm1", "Cm2", "Cr0", "Cr2", "Iz")

#: The simulator's coefficients, ``deep_dynamics.yaml`` of the records' repository (its
#: PARAMETERS and VEHICLE_SPECS): value, Min, Max. A test reads the shipped file against them.
SIMULATOR: dict[str, tuple[float, float, float]] = {
    "Bf": (5.579, 5.0, 30.0), "Cf": (1.2, 0.5, 2.0), "Df": (0.192, 0.1, 0.9),
    "Ef": (-0.083, -2.0, 0.0), "Br": (5.3852, 5.0, 30.0), "Cr": (1.2691, 0.5, 2.0),
    "Dr": (0.1737, 0.1, 0.9), "Er": (-0.019, -2.0, 0.0), "Cm1": (0.287, 0.1435, 0.574),
    "Cm2": (0.0545, 0.02725, 0.109), "Cr0": (0.0518, 0.0259, 0.1036),
    "Cr2": (0.00035, 1.75e-4, 7.0e-4), "Iz": (27.8e-6, 1.39e-5, 5.56e-5),
    "Shf": (-0.0013, -0.02, 0.02), "Svf": (0.00043, -0.003, 0.003),
    "Shr": (-0.00376, -0.02, 0.02), "Svr": (0.00091, -0.003, 0.003),
}
VEHICLE = {"m": 0.041, "lf": 0.029, "lr": 0.033}
IDENTIFIED = ("Bf", "Cf", "Df", "Br", "Cr", "Dr", "Cm1", "Cm2", "Cr0", "Iz")
UNITS = ("1/rad", "1", "N", "1/rad", "1", "N", "N", "N s/m", "N", "kg m²")
TRACKS = {"ETHZ": "DYN-PP-ETHZ.npz", "ETHZMobil": "DYN-PP-ETHZMobil.npz"}
CHANNELS = (("vx", "m/s"), ("vy", "m/s"), ("r", "rad/s"))
#: The records' sampling step (s).
DT = 0.02


@dataclasses.dataclass(frozen=True)
class BayesraceConfig(ProblemConfig):
    """``track`` fitted (the other held out), ``substeps``, ``objective``, ``data_dir``."""

    track: Literal["ETHZ", "ETHZMobil"] = "ETHZ"
    substeps: int = 10
    objective: str = "ml_profiled"
    data_dir: str | None = None

    def __post_init__(self) -> None:
        estimators.check_objective(self.objective, None)
        if self.track not in TRACKS:
            raise ConfigError("problem.track", self.track, "ETHZ or ETHZMobil")
        if not (isinstance(self.substeps, int) and 1 <= self.substeps <= 100):
            raise ConfigError("problem.substeps", self.substeps, "an integer in [1, 100]")
        for name in TRACKS.values():
            third_party.verified(name, self.data_dir)


class TrackRecord:
    """One record and the continuous-time model's simulation of it."""

    def __init__(self, record: third_party.SimulatorRecord, substeps: int) -> None:
        self.record = record
        self.substeps = substeps
        self.full = np.array([SIMULATOR[k][0] for k in DYNAMIC_ROWS])
        self.rows = [DYNAMIC_ROWS.index(k) for k in IDENTIFIED]

    def simulate(self, X: np.ndarray) -> np.ndarray:
        """``vx, vy, r`` ``(n, 3, N)`` of the rows ``X``; NaN rows where one is not > 0."""
        from .kernel import dynamic_single_track

        X = np.atleast_2d(np.asarray(X, dtype=float))
        ok = np.all(np.isfinite(X) & (X > 0), axis=1)
        N = self.record.t.size
        out = np.full((X.shape[0], 3, N), np.nan)
        if np.any(ok):
            P = np.repeat(self.full[:, None], int(ok.sum()), axis=1)
            P[self.rows] = X[ok].T
            y = np.empty((N, 3, P.shape[1]))
            with np.errstate(all="ignore"):
                dynamic_single_track(np.ascontiguousarray(P), self.record.drive,
                                     self.record.steer, DT, self.substeps, VEHICLE["m"],
                                     VEHICLE["lf"], VEHICLE["lr"],
                                     np.ascontiguousarray(self.record.states[:, 0]), y)
            out[ok] = y.transpose(2, 1, 0)
        return out


class BayesraceProblem(ChannelFit, Problem):
    """The Bayesrace records fitted by the continuous-time model (module docstring)."""

    Config = BayesraceConfig
    name = "bayesrace"
    family = "single-track dynamic, third-party simulator"
    rows_independent: ClassVar[bool] = True
    channels = CHANNELS

    def __init__(self, config: BayesraceConfig) -> None:
        super().__init__(config)
        held_out = next(t for t in TRACKS if t != config.track)
        self.fit = TrackRecord(third_party.read_simulator_record(TRACKS[config.track],
                                                                 config.data_dir),
                               config.substeps)
        self.held_out = TrackRecord(third_party.read_simulator_record(TRACKS[held_out],
                                                                      config.data_dir),
                                    config.substeps)
        self.measured, self.t = self.fit.record.states, self.fit.record.t
        self.weights = estimators.weights(
            config.objective, self.measured,
            1.0 / np.linalg.norm(self.measured, axis=1, keepdims=True), None)
        self._x_true = np.array([SIMULATOR[k][0] for k in IDENTIFIED])
        self._bounds = Bounds(np.array([SIMULATOR[k][1] for k in IDENTIFIED]),
                              np.array([SIMULATOR[k][2] for k in IDENTIFIED]), IDENTIFIED,
                              UNITS)

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    @property
    def x_true(self) -> np.ndarray:
        return self._x_true.copy()

    def computed(self, X: np.ndarray) -> np.ndarray:
        return self.fit.simulate(X)

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        """``NoRE`` (%), the held-out ``val_rms_r`` (rad/s), ``val_rms_vx``, ``val_rms_vy``."""
        x = np.asarray(x, dtype=float).reshape(-1)
        out = {"NoRE": float(np.linalg.norm(relative_errors_percent(x, self._x_true)))}
        sim = self.held_out.simulate(x[None])[0]
        err = np.sqrt(np.mean((self.held_out.record.states - sim) ** 2, axis=1))
        for (name, _), e in zip(CHANNELS, err, strict=True):
            out[f"val_rms_{name}"] = float(e) if np.isfinite(e) else float("inf")
        return out

    def describe(self) -> dict[str, Any]:
        fixed = {k: SIMULATOR[k][0] for k in DYNAMIC_ROWS if k not in IDENTIFIED}
        return {
            "samples": int(self.measured.shape[1]),
            "known": {**VEHICLE, **fixed},
            "record": {"fitted": TRACKS[self.config.track],
                       "held_out": self.held_out.record.name,
                       "made_by": "the Bayesrace simulator: explicit Euler at 50 Hz"},
            "fitted_model": {"solver": "RK4", "dt_s": DT / self.config.substeps},
            "noise": {"model": "none added (model error only)",
                      "channels": [c for c, _ in CHANNELS]},
            "truth": self._x_true.tolist(),
            "f_at_true": float(self.evaluate(self._x_true[None])[0]),
            "metric_units": {"NoRE": "%", "val_rms_r": "rad/s", "val_rms_vx": "m/s",
                             "val_rms_vy": "m/s"},
        }

    def content_digest(self) -> str | None:
        return "+".join(third_party.SHA256[n][:16] for n in TRACKS.values())
