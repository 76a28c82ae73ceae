"""The estimator as a choice: one record's residuals under four objectives.

An identification problem compares a measured record ``y`` (``p`` channels of ``N_c`` samples)
with a model's response ``g(θ)``. *Which* distance is minimised is the estimator, and it sets
the floor a record allows as much as the data do. The four built in (``problem.objective``):

* ``eq3``: Eq. 3 of the problem's source, a sum of one Euclidean norm per channel, each over a
  reference norm (the problem says which). Not a likelihood: its floor can sit far above the
  Cramér–Rao bound of the data.
* ``ols``: ordinary least squares, ``f = ||y - g||² / ||y||²`` over all channels at once
  (channels in their own units, unweighted).
* ``ml``: the Gaussian likelihood of a **stated** noise model (level and kind known),
  ``f = mean((y - g)² / (2 σ²))`` (the negative log-likelihood per sample without its
  constant). Additive noise: ``σ_c = level × rms(y_c)``. Multiplicative noise (``σ_k =
  level × |z_k|``, ``z`` the clean signal) and uniform noise (the same over √3): ``σ_k`` is the
  noise model's at a *leave-one-out* estimate of ``|z_k|`` from the neighbouring samples
  (:func:`leave_one_out`: the mean of the two neighbours, not below the smaller one-sided
  extrapolation, so a jump in the signal is not taken for a zero crossing), floored at
  ``SIGMA_FLOOR × level × rms(y_c)`` (:func:`plug_in_sigma`). Each sample's weight is then
  independent of that sample's own noise, so the weighted residuals have mean zero at the truth
  and the estimator is unbiased (tested on a linear-Gaussian model and on a half car's
  records); weights from the sample itself (``level × |y_k|``, the rule before round four)
  favour the samples whose noise made them small and bias the estimates by several standard
  errors. Why not ``σ`` from the model's prediction ``level × |g_k(θ)|`` with the ``Σ log
  σ_k(θ)`` term (the exact likelihood)? Its value is unbounded wherever the model's response
  crosses zero at a sample where the record does not, so every sample adds a wall across the
  parameter space: a least-squares search from random starts stops far above the optimum,
  while from the truth it is only slightly more precise than the leave-one-out weights
  (measured in docs/estimators.md). Uniform
  noise is treated by its variance (a quasi-likelihood). Needs the noise stated: refused for
  a record whose noise level is not known (:func:`check_objective`).
* ``ml_profiled``: the Gaussian likelihood with each channel's σ **unknown** (additive, constant
  along the channel) and profiled out: ``-log L = Σ_c N_c/2 · log(RSS_c / N_c) + const``. For
  measured records, where no noise level is known; the value reported is the monotone
  ``f = Π_c (rms(y_c - g_c) / rms(y_c))^(N_c / N)``, the geometric mean of the channels'
  relative rms residuals weighted by their samples (dimensionless, > 0; ``-log L = N log f +
  const``). Its residuals (:func:`residuals_and_value`) are scaled per channel so that their
  norm is ``√N · f`` and their Gauss–Newton matrix at the optimum is the likelihood's
  (weights ``N_c / RSS_c``): ``lsq`` minimises it as it is.

**How a problem uses them**: multiply each raw residual ``y - g`` by :func:`weights` (fixed
for a record: ``eq3_scale``, ``1 / ||y||``, ``1 / σ`` or ``1 / rms(y_c)``), then hand the
weighted residuals ``(n, p, N)`` to :func:`residuals_and_value`, which returns the objective
and the residual vectors an optimizer sees (for ``ml_profiled`` a per-candidate rescaling; for
the others the weighted residuals themselves). :func:`groups` gives the residual groups (the
channels for ``eq3``, one group otherwise). The weighted residuals *before* the rescaling
are the problem's ``fisher_residuals`` (their weights do not depend on ``θ``): the
Cramér–Rao bound differentiates them. A problem that offers the choice validates it with
:func:`check_objective`, passing ``None`` as the noise level when the noise is not known (a
measured record).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from .errors import ConfigError

Objective = Literal["eq3", "ols", "ml", "ml_profiled"]
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
    """Each sample's magnitude estimated from its neighbours only, ``(p, N)``: the mean of the
    samples before and after it, ``|(y_{k-1} + y_{k+1}) / 2|``, but not below the smaller of
    the two one-sided linear extrapolations ``|2 y_{k-1} - y_{k-2}|`` and ``|2 y_{k+1} -
    y_{k+2}|``: next to a jump in the signal (a step input) the mean of the neighbours can pass
    near zero where the signal does not, and one side's extrapolation is then right. At the
    ends the one side that exists. Independent of the sample's own noise when the noise is
    independent from sample to sample. Needs ``N >= 3``."""
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
    """The ``σ`` of each sample ``(p, N)`` the ``ml`` objective weighs by: the noise model's
    (:func:`noise_sigma`) at the leave-one-out estimate of the clean record
    (:func:`leave_one_out`) for multiplicative and uniform noise, at the record for additive
    noise (one ``σ`` per channel from its rms); floored at ``SIGMA_FLOOR × level × rms(y_c)``
    so a sample near zero does not get an infinite weight."""
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


def residuals_and_value(objective: str, weighted: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    """The objective ``(n,)`` and the residual vectors an optimizer minimises ``(n, p N)``
    (channels one after another) of weighted residuals ``(n, p, N)`` (raw residuals times
    :func:`weights`). ``eq3``: the sum of the channel norms; ``ols``: the sum of squares;
    ``ml``: half the mean square; the residuals are the weighted ones. ``ml_profiled``:
    ``f = Π_c (rms_c)^(N_c / N)`` of the channels' rms ``rms_c`` and residuals ``r_c · f /
    rms_c`` (norm ``√N · f``; a channel fitted exactly gives ``f = 0`` and zero residuals).
    ``inf`` (value and residuals) where a row is not finite."""
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
