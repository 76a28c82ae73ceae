"""Control-parameter adaptation of the success-history DE family (JADE, SHADE, L-SHADE).

Pure functions of arrays and a ``numpy.random.Generator``, each tested on hand-built
success histories:

* :func:`sample_cr`, :func:`sample_f`: per-target crossover rates ``CR_i ~ N(mu, 0.1)`` clipped
  to [0, 1] and scale factors ``F_i ~ Cauchy(mu, 0.1)`` cut to 1 above and drawn again when
  ``<= 0`` (Zhang and Sanderson 2009, Sec. IV-C/D; the same in SHADE and L-SHADE);
* :func:`weighted_mean`, :func:`lehmer_mean`: the means the three algorithms average their
  successful parameters with;
* :func:`jade_update`: JADE's ``mu <- (1 - c) mu + c mean(S)``;
* :class:`SuccessHistory`: SHADE's memories ``M_CR``, ``M_F`` of ``H`` entries, written in turn
  with means weighted by the improvement each success made; with ``lehmer_cr`` and
  ``terminal`` L-SHADE's variant (Lehmer mean for ``M_CR`` too, and the terminal value that
  freezes an entry's CR at 0 once the successes all had ``CR = 0``).

A "success" is a trial that strictly improved on its parent; ``S_CR``, ``S_F`` are the rates
and factors those trials used and ``delta`` the improvements ``|f(parent) - f(trial)|``.
"""

from __future__ import annotations

import numpy as np

#: standard deviation of the normal CR draws and scale of the Cauchy F draws (all 3 papers)
SPREAD = 0.1


def sample_cr(rng: np.random.Generator, mu: np.ndarray | float, size: int) -> np.ndarray:
    """``size`` crossover rates ``CR_i ~ N(mu_i, 0.1)`` clipped to [0, 1]; ``CR_i = 0`` where
    ``mu_i`` is NaN (L-SHADE's terminal value). ``mu``: a scalar or ``(size,)``."""
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
    """``size`` scale factors ``F_i ~ Cauchy(mu_i, 0.1)``: a draw above 1 becomes 1, a draw
    ``<= 0`` is drawn again (so ``F_i`` is in (0, 1]). ``mu``: a scalar or ``(size,)``."""
    mu = np.asarray(mu, dtype=float)
    F = mu + SPREAD * rng.standard_cauchy(size)
    bad = F <= 0.0
    while bad.any():
        F[bad] = (mu[bad] if mu.ndim else mu) + SPREAD * rng.standard_cauchy(int(bad.sum()))
        bad = F <= 0.0
    return np.minimum(F, 1.0, out=F)


def improvement_weights(delta: np.ndarray) -> np.ndarray:
    """SHADE's weights ``w_k = delta_k / sum(delta)``. An infinite improvement (the parent's
    simulation had failed, ``f = inf``) gets all the weight, shared equally with the other
    infinite ones, so the weights stay finite and sum to 1."""
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
    """Lehmer mean ``sum w_k S_k^2 / sum w_k S_k`` (uniform weights when ``w`` is None): it
    leans towards the larger values, which counters the pull of the CR/F draws towards small
    factors. NaN when every ``S_k`` is 0 (only a CR can be 0)."""
    S = np.asarray(S, dtype=float)
    w = np.ones_like(S) if w is None else np.asarray(w, dtype=float)
    den = np.sum(w * S)
    return float(np.sum(w * S * S) / den) if den > 0.0 else float("nan")


def jade_update(
    mu_cr: float, mu_f: float, S_CR: np.ndarray, S_F: np.ndarray, c: float
) -> tuple[float, float]:
    """JADE's adaptation after a generation: ``mu_CR <- (1 - c) mu_CR + c mean_A(S_CR)`` and
    ``mu_F <- (1 - c) mu_F + c mean_L(S_F)`` (arithmetic and Lehmer means, unweighted). With
    no success the means are undefined and both stay as they are."""
    if len(S_CR) == 0:
        return mu_cr, mu_f
    return ((1.0 - c) * mu_cr + c * weighted_mean(S_CR),
            (1.0 - c) * mu_f + c * lehmer_mean(S_F))


class SuccessHistory:
    """SHADE's historical memories: ``H`` entries of ``M_CR`` and ``M_F``, all 0.5 at first.

    Each target draws one entry ``r_i`` uniformly and samples ``CR_i``, ``F_i`` around it
    (:meth:`means`); after a generation with at least one success, entry ``k`` is overwritten
    by the improvement-weighted means of that generation's successes and ``k`` moves to the
    next entry (cyclically). ``lehmer_cr``: the ``M_CR`` mean is Lehmer (L-SHADE) instead of
    arithmetic (SHADE). ``terminal``: L-SHADE's terminal value, kept as NaN: an entry whose
    successes all had ``CR = 0``, or that already was terminal, becomes (stays) terminal, and
    a target that draws it uses ``CR = 0``.
    """

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
