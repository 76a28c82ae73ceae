"""The estimator as a choice: one record's residuals under four objectives (``eq3``, ``ols``,
``ml``, ``ml_profiled``).

An identification problem compares a measured record ``y`` (``p`` channels of ``N_c``
samples) with a model's response ``g(θ)``; *which* distance is minimised is the estimator,
and it sets the floor a record allows as much as the data do (``problem.objective``). What
each objective is, why ``ml`` weighs a sample by its neighbours (:func:`leave_one_out`) and
how a problem uses them (:func:`weights`, :func:`residuals_and_value`, :func:`groups`,
:func:`check_objective`, ``fisher_residuals``): docs/estimators.md.
"""

from __future__ import annotations

import numpy as np

from .errors import ConfigError

OBJECTIVES: tuple[str, ...] = ("eq3", "ols", "ml", "ml_profiled")
#: The smallest plug-in sigma of a multiplicative model, as a fraction of ``level × rms``.
SIGMA_FLOOR = 1e-3
#: What each objective is, in words the report and the docs use.
DESCRIPTION = {
    "eq3": "the sum of channel norms of Eq. 3",
    "ols": "ordinary least squares",
    "ml": "the Gaussian likelihood of the stated noise model",
    "ml_profiled": "the Gaussian likelihood with each channel's noise level unknown "
                   "(profiled out)",
}


def check_objective(objective: str, noise_level: float | None,
                    key: str = "problem.objective") -> None:
    """Refuse an unknown objective, and ``ml`` where no noise level is stated
    (``noise_level`` ``None``, e.g. a measured record, or not > 0), naming ``key``."""
    if objective not in OBJECTIVES:
        raise ConfigError(key, objective, "one of " + ", ".join(OBJECTIVES))
    if objective == "ml" and not (noise_level is not None and noise_level > 0):
        why = ("no noise level is stated for this record" if noise_level is None
               else "the noise level is 0")
        raise ConfigError(key, objective, f"eq3, ols or ml_profiled: {why}, and ml weighs "
                          "samples by the stated noise's sigma (ml_profiled estimates each "
                          "channel's sigma from the residuals)")


def noise_sigma(clean: np.ndarray, level: float, model: str) -> np.ndarray:
    """The standard deviation of the simulated noise per sample ``(p, N)``, from the clean
    channels ``(p, N)``: ``level × |z|`` (multiplicative), ``level × rms(z_c)`` (additive),
    ``level × |z| / √3`` (uniform, ``z (1 + level u)`` with ``u ~ U(-1, 1)``). Units of ``z``."""
    clean = np.asarray(clean, dtype=float)
    rms = np.sqrt(np.mean(clean**2, axis=1, keepdims=True))
    if model == "additive":
        return np.broadcast_to(level * rms, clean.shape).copy()
    if model == "multiplicative":
        return level * np.abs(clean)
    if model == "uniform":
        return level * np.abs(clean) / np.sqrt(3.0)
    raise ValueError(f"unknown noise model {model!r}")


def leave_one_out(measured: np.ndarray) -> np.ndarray:
    """Each sample's magnitude from its neighbours only, ``(p, N)``: ``|(y_{k-1} +
    y_{k+1}) / 2|``, not below the smaller one-sided extrapolation ``|2 y_{k∓1} - y_{k∓2}|``
    (next to a jump the mean can pass near zero where the signal does not); at the ends the
    one side that exists. Needs ``N >= 3``."""
    y = np.asarray(measured, dtype=float)
    if y.shape[-1] < 3:
        raise ValueError("a leave-one-out estimate needs at least 3 samples per channel")
    centre = np.empty_like(y)
    centre[..., 1:-1] = 0.5 * (y[..., :-2] + y[..., 2:])
    centre[..., 0], centre[..., -1] = y[..., 1], y[..., -2]
    left = np.full_like(y, np.nan)
    left[..., 2:] = 2 * y[..., 1:-1] - y[..., :-2]
    right = np.full_like(y, np.nan)
    right[..., :-2] = 2 * y[..., 1:-1] - y[..., 2:]
    return np.fmax(np.abs(centre), np.fmin(np.abs(left), np.abs(right)))


def plug_in_sigma(measured: np.ndarray, level: float, model: str) -> np.ndarray:
    """The ``σ`` ``(p, N)`` the ``ml`` objective weighs by: the noise model's at the
    leave-one-out estimate of the clean record (at the record for additive noise), floored
    at ``SIGMA_FLOOR × level × rms(y_c)`` (no infinite weight)."""
    measured = np.asarray(measured, dtype=float)
    rms = np.sqrt(np.mean(measured**2, axis=1, keepdims=True))
    at = measured if model == "additive" else leave_one_out(measured)
    return np.maximum(noise_sigma(at, level, model), SIGMA_FLOOR * level * rms)


def weights(objective: str, measured: np.ndarray, eq3_scale: np.ndarray | float,
            sigma: np.ndarray | None) -> np.ndarray:
    """What a raw residual ``y - g`` ``(p, N)`` is multiplied by, ``(p, N)``: ``eq3_scale``
    (``(p, 1)`` or a number, the problem's Eq. 3 convention), ``1 / ||y||`` (``ols``),
    ``1 / σ`` (``ml``, ``sigma`` from :func:`plug_in_sigma`) or ``1 / rms(y_c)``
    (``ml_profiled``: dimensionless channels; the likelihood does not depend on it)."""
    measured = np.asarray(measured, dtype=float)
    if objective == "eq3":
        return np.broadcast_to(np.asarray(eq3_scale, dtype=float), measured.shape).copy()
    if objective == "ols":
        return np.full(measured.shape, 1.0 / np.linalg.norm(measured))
    if objective == "ml":
        if sigma is None:
            raise ValueError("the ml objective needs the plug-in sigma")
        return 1.0 / np.asarray(sigma, dtype=float)
    if objective == "ml_profiled":
        rms = np.sqrt(np.mean(measured**2, axis=1, keepdims=True))
        return np.broadcast_to(1.0 / rms, measured.shape).copy()
    raise ValueError(f"unknown objective {objective!r}")


def value(objective: str, weighted: np.ndarray) -> np.ndarray:
    """The objective of weighted residuals ``(n, p, N)``, ``(n,)``; ``inf`` where a row is not
    finite (see :func:`residuals_and_value`)."""
    return residuals_and_value(objective, weighted)[0]


def residuals_and_value(objective: str, weighted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The objective ``(n,)`` and the residual vectors an optimizer minimises ``(n, p N)`` of
    weighted residuals ``(n, p, N)``: ``eq3`` the sum of channel norms, ``ols`` the sum of
    squares, ``ml`` half the mean square (residuals as weighted); ``ml_profiled``
    ``f = Π_c rms_c^(N_c / N)``, residuals ``r_c · f / rms_c``. ``inf`` where a row is not
    finite."""
    R = np.asarray(weighted, dtype=float)
    if R.ndim != 3:
        raise ValueError(f"weighted residuals are (n, p, N), not {R.shape}")
    n = R.shape[0]
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        if objective == "eq3":
            f = np.linalg.norm(R, axis=2).sum(axis=1)
        elif objective == "ols":
            f = np.sum(R**2, axis=(1, 2))
        elif objective == "ml":
            f = 0.5 * np.mean(R**2, axis=(1, 2))
        elif objective == "ml_profiled":
            rms = np.sqrt(np.mean(R**2, axis=2))  # (n, p)
            f = np.exp(np.mean(np.log(rms), axis=1))  # equal N_c: the weights N_c / N are 1/p
            R = np.where(rms[..., None] > 0, R * (f[:, None] / rms)[..., None], 0.0)
        else:
            raise ValueError(f"unknown objective {objective!r}")
    flat = R.reshape(n, -1)
    bad = ~(np.isfinite(f) & np.all(np.isfinite(flat), axis=1))
    f[bad] = np.inf
    flat[bad] = np.inf
    return f, flat


def groups(objective: str, channels: int, samples: int) -> np.ndarray:
    """The residual group of each entry, ``(channels × samples,)``: the channel for ``eq3``
    (a sum of norms), one group for the others (a sum of squares)."""
    if objective == "eq3":
        return np.repeat(np.arange(channels), samples)
    return np.zeros(channels * samples, dtype=int)
