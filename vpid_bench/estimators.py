"""The estimator as a choice: one problem's residuals under three objectives.

An identification problem compares a measured record ``y`` (``p`` channels of ``N`` samples)
with a model's response ``g(θ)``. *Which* distance is minimised is the estimator, and it sets
the floor a record allows as much as the data do. The three built in (``problem.objective``):

* ``eq3``: Eq. 3 of the problem's source, a sum of one Euclidean norm per channel, each over a
  reference norm (the problem says which). Not a likelihood: its floor can sit far above the
  Cramér–Rao bound of the data.
* ``ols``: ordinary least squares, ``f = ||y - g||² / ||y||²`` over all channels at once
  (channels in their own units, unweighted).
* ``ml``: the Gaussian likelihood of the stated noise model, ``f = mean((y - g)² / (2 σ²))``
  (the negative log-likelihood per sample without its constant), with each sample's ``σ``
  plugged in from the record (:func:`plug_in_sigma`): for additive noise
  ``σ_c = level × rms(y_c)``; for multiplicative noise ``σ_k = level × |y_k|`` (the noise
  model's variance at the measured value; a floor of ``SIGMA_FLOOR × level × rms(y_c)`` keeps
  it positive). For additive noise this is the likelihood with ``σ`` estimated from the record;
  for multiplicative noise it is weighted least squares with weights from the record, not the
  likelihood with a ``θ``-dependent variance (that one adds ``Σ log σ_k(θ)`` and needs a
  solver for it). Uniform noise is treated by its variance (a Gaussian quasi-likelihood).

``eq3`` is a sum of norms (its residual groups are the channels: least-squares optimizers
reweight each channel by ``1 / ||r_c||``); ``ols`` and ``ml`` are sums of squares (one group).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from .errors import ConfigError

Objective = Literal["eq3", "ols", "ml"]
OBJECTIVES: tuple[str, ...] = ("eq3", "ols", "ml")
#: The smallest plug-in sigma of a multiplicative model, as a fraction of ``level × rms``.
SIGMA_FLOOR = 1e-3
#: What each objective is, in words the report and the docs use.
DESCRIPTION = {
    "eq3": "the sum of channel norms of Eq. 3",
    "ols": "ordinary least squares",
    "ml": "the Gaussian likelihood of the stated noise model",
}


def check_objective(objective: str, noise_level: float, key: str = "problem.objective"
                    ) -> None:
    """Refuse an unknown objective, and ``ml`` without a noise level (its weights are the
    noise's), naming ``key``."""
    if objective not in OBJECTIVES:
        raise ConfigError(key, objective, "one of " + ", ".join(OBJECTIVES))
    if objective == "ml" and not noise_level > 0:
        raise ConfigError(key, objective, "eq3 or ols when the noise level is 0 (the "
                          "likelihood weighs samples by the noise's sigma)")


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


def plug_in_sigma(measured: np.ndarray, level: float, model: str) -> np.ndarray:
    """The ``σ`` of each sample ``(p, N)`` the ``ml`` objective weighs by: the noise model's
    at the measured values (:func:`noise_sigma` of the record), floored at ``SIGMA_FLOOR ×
    level × rms(y_c)`` so a sample at zero does not get an infinite weight."""
    measured = np.asarray(measured, dtype=float)
    rms = np.sqrt(np.mean(measured**2, axis=1, keepdims=True))
    return np.maximum(noise_sigma(measured, level, model), SIGMA_FLOOR * level * rms)


def weights(objective: str, measured: np.ndarray, eq3_scale: np.ndarray,
            sigma: np.ndarray | None) -> np.ndarray:
    """What a raw residual ``y - g`` ``(p, N)`` is multiplied by, ``(p, N)``: ``eq3_scale``
    (``(p, 1)`` or a number, the problem's Eq. 3 convention), ``1 / ||y||`` (``ols``) or
    ``1 / σ`` (``ml``, ``sigma`` from :func:`plug_in_sigma`)."""
    measured = np.asarray(measured, dtype=float)
    if objective == "eq3":
        return np.broadcast_to(np.asarray(eq3_scale, dtype=float), measured.shape).copy()
    if objective == "ols":
        return np.full(measured.shape, 1.0 / np.linalg.norm(measured))
    if objective == "ml":
        if sigma is None:
            raise ValueError("the ml objective needs the plug-in sigma")
        return 1.0 / np.asarray(sigma, dtype=float)
    raise ValueError(f"unknown objective {objective!r}")


def value(objective: str, weighted: np.ndarray) -> np.ndarray:
    """The objective of weighted residuals ``(n, p, N)``, ``(n,)``; ``inf`` where a row is not
    finite. ``eq3``: the sum of the channel norms; ``ols``: the sum of squares; ``ml``: half
    the mean square."""
    R = np.asarray(weighted, dtype=float)
    with np.errstate(invalid="ignore", over="ignore"):
        if objective == "eq3":
            f = np.linalg.norm(R, axis=2).sum(axis=1)
        elif objective == "ols":
            f = np.sum(R**2, axis=(1, 2))
        elif objective == "ml":
            f = 0.5 * np.mean(R**2, axis=(1, 2))
        else:
            raise ValueError(f"unknown objective {objective!r}")
    f[~np.isfinite(f)] = np.inf
    return f


def groups(objective: str, channels: int, samples: int) -> np.ndarray:
    """The residual group of each entry, ``(channels × samples,)``: the channel for ``eq3``
    (a sum of norms), one group for the sums of squares."""
    if objective == "eq3":
        return np.repeat(np.arange(channels), samples)
    return np.zeros(channels * samples, dtype=int)
