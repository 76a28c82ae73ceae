"""``problem=racecar``: a full-scale autonomous racecar's tyres and yaw inertia from its logs
(measured, no truth; GPL-3.0, read by :mod:`.third_party`): the single-track model with ``vx``
an input (:func:`.kernel.scheduled_single_track`, SI units) predicts windows of the logs, judged
on held-out windows against the naive predictor (each window's first state held). The
equations, the windows, the box (:data:`TYRES`) and the metrics: docs/measured.md, "Racecar".
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar, Literal

import numpy as np

from vpid_bench import Bounds, ChannelFit, ConfigError, Problem, ProblemConfig, estimators

from . import third_party
from .problem import _check

#: The car's constants (``deep_dynamics_iac.yaml``, VEHICLE_SPECS; a test reads the file).
VEHICLE = {"m": 790.0, "lf": 1.248, "lr": 1.7328}
LOGS = {"putnam": "Putnam_park2023_run4_2.csv", "lvms": "LVMS_23_01_04_B.csv"}
PARTS = tuple(f"{log}{half}" for log in LOGS for half in ("", "_first_half", "_second_half"))
CHANNELS = (("vy", "m/s"), ("r", "rad/s"))
TYRES = {
    "linear": (("Cf", "Cr", "Iz"), ("N/rad", "N/rad", "kg m²"),
               (1e4, 1e4, 500.0), (4e5, 4e5, 2000.0)),
    "magic_formula": (("Bf", "Cf", "Df", "Br", "Cr", "Dr", "Iz"),
                      ("1/rad", "1", "N", "1/rad", "1", "N", "kg m²"),
                      (5.0, 0.5, 100.0, 5.0, 0.5, 100.0, 500.0),
                      (30.0, 2.0, 10000.0, 30.0, 2.0, 10000.0, 2000.0)),
}
NAIVE = "naive (each state held at its starting value)"


def _log_of(part: str) -> str:
    return part.split("_")[0]


@dataclasses.dataclass(frozen=True)
class RacecarConfig(ProblemConfig):
    """``fit`` / ``validate``: a log, whole or ``_first_half`` / ``_second_half`` (not
    overlapping); ``horizon_s`` (s), ``min_speed`` (m/s), ``substeps``, ``steer_delay_s`` (s),
    ``objective`` (``ml`` needs a stated noise level), ``data_dir`` (see the module)."""

    tyres: Literal["linear", "magic_formula"] = "linear"
    fit: str = "putnam_first_half"
    validate: str = "putnam_second_half"
    horizon_s: float = 1.0
    min_speed: float = 5.0
    substeps: int = 4
    steer_delay_s: float = 0.0
    objective: str = "ml_profiled"
    data_dir: str | None = None

    def __post_init__(self) -> None:
        estimators.check_objective(self.objective, None)
        _check([
            ("tyres", self.tyres in TYRES, "linear or magic_formula"),
            ("fit", self.fit in PARTS, "one of " + ", ".join(PARTS)),
            ("validate", self.validate in PARTS, "one of " + ", ".join(PARTS)),
            ("horizon_s", isinstance(self.horizon_s, (int, float)) and
             0.08 <= self.horizon_s <= 10, "a window in [0.08, 10] s (2 to 250 samples)"),
            ("min_speed", isinstance(self.min_speed, (int, float)) and
             1 <= self.min_speed <= 30, "a speed in [1, 30] m/s"),
            ("substeps", isinstance(self.substeps, int) and 1 <= self.substeps <= 50,
             "an integer in [1, 50]"),
            ("steer_delay_s", isinstance(self.steer_delay_s, (int, float)) and
             0 <= self.steer_delay_s <= 1, "a delay in [0, 1] s"),
        ], self)
        if _log_of(self.fit) == _log_of(self.validate) and (
                self.fit == self.validate or _log_of(self.fit) in (self.fit, self.validate)):
            raise ConfigError("problem.validate", self.validate, f"a part that does not "
                              f"overlap fit={self.fit} (the other log, or the other half)")
        for log in {_log_of(self.fit), _log_of(self.validate)}:
            third_party.verified(LOGS[log], self.data_dir)


class Windows:
    """The prediction windows of one part of a log, the logged inputs and states."""

    def __init__(self, log: third_party.RacecarLog, part: str, config: RacecarConfig) -> None:
        self.dt = float(np.median(np.diff(log.t)))
        N = log.t.size
        half = slice(0, N // 2) if part.endswith("first_half") else (
            slice(N // 2, N) if part.endswith("second_half") else slice(0, N))
        self.H = int(round(config.horizon_s / self.dt))
        fast = np.zeros(N, dtype=bool)
        fast[half] = log.vx[half] >= config.min_speed
        starts, k = [], half.start
        while k + self.H <= half.stop:
            if fast[k:k + self.H].all():
                starts.append(k)
                k += self.H
            else:
                k += 1
        if len(starts) < 2:
            raise ConfigError("problem.min_speed", config.min_speed, f"a speed the car holds "
                              f"for {config.horizon_s} s at least twice in {part}")
        self.starts = np.array(starts, dtype=np.int64)
        self.vx = np.ascontiguousarray(log.vx)
        self.delta = np.ascontiguousarray(
            np.interp(log.t - config.steer_delay_s, log.t, log.delta))
        idx = self.starts[:, None] + np.arange(self.H)[None]
        self.t = log.t[idx]
        #: Logged ``(vy, r)`` of each window's samples, ``(W, H, 2)``.
        self.measured = np.stack([log.vy[idx], log.r[idx]], axis=2)
        self.x0 = np.ascontiguousarray(self.measured[:, 0, :])
        self.name = part

    def predict(self, P: np.ndarray, linear: bool, substeps: int) -> np.ndarray:
        """The model's ``(vy, r)`` ``(n, W, H, 2)`` for the parameter columns ``P``."""
        from .kernel import scheduled_single_track

        W, n = self.starts.size, P.shape[1]
        y = np.empty((W, self.H, 2, n))
        with np.errstate(all="ignore"):
            scheduled_single_track(np.ascontiguousarray(P), linear, self.vx, self.delta,
                                   self.starts, self.H, substeps, self.dt, VEHICLE["m"],
                                   VEHICLE["lf"], VEHICLE["lr"], self.x0, y)
        return y.transpose(3, 0, 1, 2)

    def naive(self) -> np.ndarray:
        """Each window's first sample held, ``(W, H, 2)``."""
        return np.repeat(self.measured[:, :1, :], self.H, axis=1)


def rms(measured: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """Per channel, the rms error over the windows' samples after the first, ``(2,)``."""
    return np.sqrt(np.mean((measured - predicted)[:, 1:, :] ** 2, axis=(0, 1)))


class RacecarProblem(ChannelFit, Problem):
    """The racecar's single-track model from one part of its logs, judged on another."""

    Config = RacecarConfig
    name = "racecar"
    family = "single-track lateral, measured"
    rows_independent: ClassVar[bool] = True
    channels = CHANNELS

    def __init__(self, config: RacecarConfig) -> None:
        super().__init__(config)
        logs = {log: third_party.read_racecar_log(LOGS[log], config.data_dir)
                for log in {_log_of(config.fit), _log_of(config.validate)}}
        self.fitted = Windows(logs[_log_of(config.fit)], config.fit, config)
        self.held_out = Windows(logs[_log_of(config.validate)], config.validate, config)
        names, units, lower, upper = TYRES[config.tyres]
        self._bounds = Bounds(np.array(lower), np.array(upper), names, units)
        self.linear = config.tyres == "linear"
        #: Channel-major ``(2, W (H - 1))`` measured samples the objective compares.
        self.measured = self._flat(self.fitted.measured[None])[0]
        self.weights = estimators.weights(
            config.objective, self.measured,
            1.0 / np.linalg.norm(self.measured, axis=1, keepdims=True), None)

    @staticmethod
    def _flat(Y: np.ndarray) -> np.ndarray:
        """``(n, W, H, 2)`` -> ``(n, 2, W (H - 1))``: the samples after each window's first."""
        return Y[:, :, 1:, :].transpose(0, 3, 1, 2).reshape(Y.shape[0], 2, -1)

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    def _predict(self, X: np.ndarray, windows: Windows) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        out = np.full((X.shape[0], windows.starts.size, windows.H, 2), np.nan)
        ok = np.all(np.isfinite(X) & (X > 0), axis=1)
        if np.any(ok):
            out[ok] = windows.predict(X[ok].T, self.linear, self.config.substeps)
        return out

    def computed(self, X: np.ndarray) -> np.ndarray:
        """The predicted samples over the fitted windows, ``(n, 2, W (H - 1))``."""
        return self._flat(self._predict(X, self.fitted))

    def _held_out_metrics(self, predicted: np.ndarray) -> dict[str, float]:
        w = self.held_out
        model, naive = rms(w.measured, predicted), rms(w.measured, w.naive())
        values = {"val_rel_naive": float(np.mean(model / naive)),
                  "val_rms_r": float(model[1]), "val_rms_vy": float(model[0])}
        return {k: (v if np.isfinite(v) else float("inf")) for k, v in values.items()}

    def metrics(self, x: np.ndarray) -> dict[str, float]:
        """The held-out metrics (docs/measured.md, "Racecar")."""
        return self._held_out_metrics(self._predict(x, self.held_out)[0])

    def comparisons(self) -> dict[str, dict[str, Any]]:
        """The naive predictor's held-out metrics, the point a model must beat."""
        naive = self._flat(self.fitted.naive()[None])
        f = float(estimators.value(self.config.objective,
                                   (self.measured[None] - naive) * self.weights)[0])
        return {NAIVE: {"metrics": self._held_out_metrics(self.held_out.naive()),
                        "note": f"no model: each window's first logged state held; objective "
                                f"on the fitted windows {f:.4g}"}}

    def signals(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Logged and predicted ``vy``, ``r`` over the held-out windows, one after another."""
        w = self.held_out
        pred = self._predict(x, w)[0]
        out = {"t": w.t.reshape(-1)}
        for c, (name, _) in enumerate(CHANNELS):
            out[f"{name}:measured"] = w.measured[:, :, c].reshape(-1)
            out[f"{name}:fitted"] = pred[:, :, c].reshape(-1)
        return out

    def describe(self) -> dict[str, Any]:
        return {
            "samples": int(self.measured.size),
            "known": dict(VEHICLE, steer_delay_s=self.config.steer_delay_s),
            "record": {"fitted": self.fitted.name, "held_out": self.held_out.name,
                       "windows": [int(self.fitted.starts.size),
                                   int(self.held_out.starts.size)],
                       "window_samples": self.fitted.H,
                       "made_by": "logged on the car at 25 Hz"},
            "noise": {"model": "additive, sigma unknown per channel (estimated from the "
                      "residuals)", "channels": [c for c, _ in CHANNELS]},
            "metric_units": {"val_rel_naive": "", "val_rms_r": "rad/s", "val_rms_vy": "m/s"},
        }

    def content_digest(self) -> str | None:
        return "+".join(third_party.SHA256[n][:16] for n in LOGS.values())
