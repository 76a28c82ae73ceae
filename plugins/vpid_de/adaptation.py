"""Control-parameter adaptation of JADE, SHADE and L-SHADE (pure functions): a success is a
trial that strictly improved on its parent; ``S_CR``, ``S_F`` the rates and factors the
successes used, ``delta`` their improvements.
"""

from __future__ import annotations

import numpy as np

#: standard deviation of the normal CR draws and scale of the Cauchy F draws (all 3 papers)
SPREAD = 0.1


def sample_cr(rng: np.random.Generator, mu: np.ndarray | float, size: int) -> np.ndarray:
    """``size`` rates ``CR_i ~ N(mu_i, 0.1)`` clipped to [0, 1]; 0 where ``mu_i`` is NaN."""
    mu = np.asarray(mu, dtype=float)
    terminal = np.isnan(mu)
    has_terminal = bool(terminal.any())
    if has_terminal:
        mu = np.where(terminal, 0.0, mu)
    cr = mu + SPREAD * rng.standard_normal(size)
    np.minimum(np.maximum(cr, 0.0, out=cr), 1.0, out=cr)
    if has_terminal:
        cr[terminal] = 0.0
    return cr


def sample_f(rng: np.random.Generator, mu: np.ndarray | float, size: int) -> np.ndarray:
    """``size`` factors ``F_i ~ Cauchy(mu_i, 0.1)``, cut to 1 above, drawn again if <= 0."""
    mu = np.asarray(mu, dtype=float)
    F = mu + SPREAD * rng.standard_cauchy(size)
    bad = F <= 0.0
    while bad.any():
        F[bad] = (mu[bad] if mu.ndim else mu) + SPREAD * rng.standard_cauchy(int(bad.sum()))
        bad = F <= 0.0
    return np.minimum(F, 1.0, out=F)


def improvement_weights(delta: np.ndarray) -> np.ndarray:
    """SHADE's ``w_k = delta_k / sum(delta)``; infinite improvements share the weight equally."""
    delta = np.asarray(delta, dtype=float)
    w = np.isinf(delta).astype(float) if np.isinf(delta).any() else delta.copy()
    total = w.sum()
    if not total > 0.0:  # all improvements zero (cannot happen for strict successes): uniform
        return np.full(delta.shape, 1.0 / delta.size)
    return w / total


def weighted_mean(S: np.ndarray, w: np.ndarray | None = None) -> float:
    """Arithmetic mean ``sum w_k S_k / sum w_k`` (uniform weights when ``w`` is None)."""
    S = np.asarray(S, dtype=float)
    w = np.ones_like(S) if w is None else np.asarray(w, dtype=float)
    return float(np.sum(w * S) / np.sum(w))


def lehmer_mean(S: np.ndarray, w: np.ndarray | None = None) -> float:
    """Lehmer mean ``sum w S^2 / sum w S`` (leans to large values); NaN when every S is 0."""
    S = np.asarray(S, dtype=float)
    w = np.ones_like(S) if w is None else np.asarray(w, dtype=float)
    den = np.sum(w * S)
    return float(np.sum(w * S * S) / den) if den > 0.0 else float("nan")


def jade_update(
    mu_cr: float, mu_f: float, S_CR: np.ndarray, S_F: np.ndarray, c: float
) -> tuple[float, float]:
    """JADE: ``mu_CR``, ``mu_F`` move a fraction ``c`` to the successes' arithmetic, Lehmer
    means (unchanged with no success)."""
    if len(S_CR) == 0:
        return mu_cr, mu_f
    return ((1.0 - c) * mu_cr + c * weighted_mean(S_CR),
            (1.0 - c) * mu_f + c * lehmer_mean(S_F))


class SuccessHistory:
    """SHADE's memories: ``H`` entries of ``M_CR``, ``M_F`` (0.5 at first), entry ``k``
    rewritten after each generation with a success, ``k`` moving on cyclically.
    ``lehmer_cr``, ``terminal`` (NaN: CR = 0 once every success had CR = 0): L-SHADE's."""

    def __init__(self, H: int, lehmer_cr: bool = False, terminal: bool = False) -> None:
        self.M_CR = np.full(H, 0.5)
        self.M_F = np.full(H, 0.5)
        self.k = 0
        self.lehmer_cr = lehmer_cr
        self.terminal = terminal

    def means(self, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The ``(M_CR[r_i], M_F[r_i])`` of ``n`` targets, each ``r_i`` uniform in ``0..H-1``."""
        r = rng.integers(0, self.M_CR.size, size=n)
        return self.M_CR[r], self.M_F[r]

    def update(self, S_CR: np.ndarray, S_F: np.ndarray, delta: np.ndarray) -> None:
        """Write entry ``k`` from one generation's successes (nothing when there are none)."""
        if len(S_CR) == 0:
            return
        w = improvement_weights(delta)
        k = self.k
        if self.terminal and (np.isnan(self.M_CR[k]) or np.max(S_CR) == 0.0):
            self.M_CR[k] = np.nan
        elif self.lehmer_cr:
            self.M_CR[k] = lehmer_mean(S_CR, w)
        else:
            self.M_CR[k] = weighted_mean(S_CR, w)
        self.M_F[k] = lehmer_mean(S_F, w)
        self.k = (k + 1) % self.M_CR.size
