"""Eq. (3), the noise added to a synthetic reference (signals ``(2, N)``: z1'', z2'', m/s^2),
and the residual path of every vehicle problem that fits measured channels."""

from __future__ import annotations

import numpy as np

from vpid_bench import estimators


def objective(responses: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Eq. (3): ``sum_i ||zr_i - zc_i|| / sum_i ||zr_i||`` ``(n,)``; inf if not finite."""
    responses = np.asarray(responses, dtype=float)
    num = np.sqrt(np.sum((responses - reference[None]) ** 2, axis=2)).sum(axis=1)
    den = float(np.sqrt(np.sum(reference**2, axis=1)).sum())
    with np.errstate(invalid="ignore"):
        f = num / den
    f[~np.isfinite(f)] = np.inf
    return f


def add_noise(clean: np.ndarray, level: float, model: str, rng: np.random.Generator) -> np.ndarray:
    """The clean signals with noise from ``rng`` (z1'' first): ``multiplicative`` ``z (1 +
    level n)``, ``additive`` ``z + level rms(z) n`` (per channel), ``uniform`` ``z (1 + level
    u)``, ``n ~ N(0, 1)``, ``u ~ U(-1, 1)``."""
    clean = np.asarray(clean, dtype=float)
    if model == "multiplicative":
        return clean * (1.0 + level * rng.standard_normal(clean.shape))
    if model == "additive":
        rms = np.sqrt(np.mean(clean**2, axis=1, keepdims=True))
        return clean + level * rms * rng.standard_normal(clean.shape)
    if model == "uniform":
        return clean * (1.0 + level * rng.uniform(-1.0, 1.0, clean.shape))
    raise ValueError(f"unknown noise model {model!r}")


def noise_summary(clean: np.ndarray, noisy: np.ndarray) -> dict[str, float]:
    """Realised noise per channel: ``rms(noisy - clean) / rms(clean)`` (dimensionless)."""
    out = {}
    for i, name in enumerate(("z1dd", "z2dd")):
        rms_clean = float(np.sqrt(np.mean(clean[i] ** 2)))
        rms_noise = float(np.sqrt(np.mean((noisy[i] - clean[i]) ** 2)))
        out[f"{name}_relative_rms"] = rms_noise / rms_clean if rms_clean > 0 else float("nan")
    return out


class ChannelFit:
    """The residuals of a problem that fits measured channels ``measured`` ``(p, N)`` with the
    objective's ``weights`` (:mod:`vpid_bench.estimators`) by :meth:`computed` ``(n, p, N)``
    (NaN rows where a row is not simulated): channels one after another, inf rows where a
    simulation fails."""

    measured: np.ndarray
    weights: np.ndarray

    def computed(self, X: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _weighted(self, X: np.ndarray) -> np.ndarray:
        """``measured - computed`` times the objective's fixed weights, ``(n, p, N)``."""
        return (self.measured[None] - self.computed(X)) * self.weights

    def evaluate_with_residuals(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return estimators.residuals_and_value(self.config.objective, self._weighted(X))

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        return self.evaluate_with_residuals(X)[0]

    def residuals(self, X: np.ndarray) -> np.ndarray:
        """What a least-squares optimizer minimises (:func:`estimators.residuals_and_value`)."""
        return self.evaluate_with_residuals(X)[1]

    def fisher_residuals(self, X: np.ndarray) -> np.ndarray:
        """``(measured_c - computed_c) / ||measured_c||`` whatever the objective."""
        scale = np.linalg.norm(self.measured, axis=1)[None, :, None]
        R = (self.measured[None] - self.computed(X)) / scale
        R[~np.all(np.isfinite(R), axis=(1, 2))] = np.inf
        return R.reshape(R.shape[0], -1)

    def fisher_groups(self) -> np.ndarray:
        """The channel of each entry of :meth:`fisher_residuals`."""
        return np.repeat(np.arange(self.measured.shape[0]), self.measured.shape[1])

    def residual_groups(self) -> np.ndarray:
        """The channels for Eq. 3 (one norm each), one group for the sums of squares."""
        return estimators.groups(self.config.objective, *self.measured.shape)

    def signal_units(self) -> dict[str, str]:
        return dict(self.channels)

    def signals(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Each channel measured and fitted at the record's times ``t``."""
        fitted = self.computed(np.asarray(x, dtype=float).reshape(1, -1))[0]
        out = {"t": self.t.copy()}
        for c, (name, _) in enumerate(self.channels):
            out[f"{name}:measured"], out[f"{name}:fitted"] = self.measured[c].copy(), fitted[c]
        return out
