"""Eq. (3) and the noise added to a synthetic reference (signals ``(2, N)``: z1'', z2'',
m/s^2)."""

from __future__ import annotations

import numpy as np


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
