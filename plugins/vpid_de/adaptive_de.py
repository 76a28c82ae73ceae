"""``optimizer=jade``, ``shade``, ``lshade``: the success-history adaptive DE family, JADE
(Zhang and Sanderson 2009), SHADE (Tanabe and Fukunaga 2013) and L-SHADE (2014): one
generation shared, each member's adaptation of ``CR_i``, ``F_i`` and ``pbest`` its own. The
steps, the keys (the papers' defaults) and where the protocol enters: docs/optimizers.md,
"The adaptive DE family".
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar, Literal

import numpy as np

from vpid_bench import Bounds, ConfigError, GenerationalOptimizer, OptimizerParams

from .adaptation import SuccessHistory, jade_update, sample_cr, sample_f
from .base import check_finite
from .kernels import (
    BOUNDS_RULES,
    BoundsRule,
    binomial_crossover,
    current_to_pbest1,
    draw_indices,
    greedy_selection,
    partner_indices,
    pbest_indices,
)
from .population import Archive, lpsr_size, round_half_up, worst_removed

#: current-to-pbest/1 needs the target and two other members (r1 != i, r2 != i, r1)
MIN_POPULATION = 3


@dataclasses.dataclass(frozen=True)
class AdaptiveDEParams(OptimizerParams):
    """``bounds``: default ``midpoint`` (the JADE and SHADE papers'); others as for DE1-DE8."""

    bounds: BoundsRule = "midpoint"

    def __post_init__(self) -> None:
        check_finite(self)
        if self.iterations < 0:
            raise ConfigError("problem.iterations", self.iterations, "an integer >= 0")


def _check_unit(key: str, value: float, closed_low: bool = False) -> None:
    ok = 0.0 <= value <= 1.0 if closed_low else 0.0 < value <= 1.0
    if not ok:
        raise ConfigError(f"optimizer.{key}", value,
                          "a number in [0, 1]" if closed_low else "a number in (0, 1]")


class AdaptiveDE(GenerationalOptimizer):
    """The generation shared by JADE, SHADE and L-SHADE (current-to-pbest/1 with the archive,
    Eq. 8, the bounds rule, selection); subclasses say how ``CR_i``, ``F_i`` and the p-best
    counts are drawn and learnt. ``nfe`` counts evaluations told."""

    label: ClassVar[str] = "adaptive_de"
    #: replace a member by an equally good trial (SHADE, L-SHADE) or only a better one (JADE)
    ties: ClassVar[bool] = False
    #: "numba" (vpid_de.fused) or "numpy" (the reference kernels): the same vectors (tested)
    engine: ClassVar[str] = "numba"

    def __init__(self, params: AdaptiveDEParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        self._repair = BOUNDS_RULES[params.bounds]
        self.population: np.ndarray | None = None
        self.fitness: np.ndarray | None = None
        self.nfe = 0
        self.archive = Archive(0, bounds.dim)
        self._CR = self._F = np.empty(0)

    def _require_population(self, key: str, value: int, size: int) -> None:
        if size < MIN_POPULATION:
            raise ConfigError(key, value, f"a population of at least {MIN_POPULATION} for "
                              f"{self.label} (current-to-pbest/1 draws two vectors besides "
                              "the target)")

    # -- what a member of the family customises --------------------------------------------------
    def initial_size(self) -> int:
        """Rows of the initial population (JADE, SHADE: the protocol's ``ps``)."""
        return self.params.ps

    def trial_count(self) -> int:
        """Trials in the next generation: one per member (L-SHADE cuts the last one short)."""
        return len(self.population)

    def parameter_means(self, n: int) -> tuple[np.ndarray | float, np.ndarray | float]:
        """The means (``mu_CR``, ``mu_F``) the ``n`` targets draw their CR_i, F_i around."""
        raise NotImplementedError

    def pbest_counts(self, n: int) -> np.ndarray | int:
        """How many of the best members each target's ``pbest`` is drawn from."""
        raise NotImplementedError

    def adapt(self, S_CR: np.ndarray, S_F: np.ndarray, delta: np.ndarray) -> None:
        """Learn from one generation's successes: their CR_i, F_i and improvements."""
        raise NotImplementedError

    def after_generation(self) -> None:
        """Hook after selection and adaptation (L-SHADE shrinks its population here)."""

    # -- GenerationalOptimizer --------------------------------------------------------------------
    def initial_population(self) -> np.ndarray:
        return self.bounds.sample(self.rng, self.initial_size())

    def start(self, X: np.ndarray, f: np.ndarray) -> None:
        self.population, self.fitness = X.copy(), f.copy()
        self.nfe += len(X)

    def next_generation(self) -> np.ndarray:
        X, f, rng = self.population, self.fitness, self.rng
        N = len(X)
        mu_cr, mu_f = self.parameter_means(N)
        CR = sample_cr(rng, mu_cr, N)
        F = sample_f(rng, mu_f, N)
        pbest = pbest_indices(rng, f, self.pbest_counts(N))
        r1 = draw_indices(rng, N, 1)[:, 0]
        XA = np.vstack([X, self.archive.rows]) if len(self.archive) else X
        r2 = partner_indices(rng, r1, len(XA))
        if self.engine == "numba":  # the same draws, then one compiled loop (vpid_de.fused)
            from .fused import BOUNDS_IDS, pbest_trials

            u = rng.random((N, X.shape[1] + 1))
            reinit = self.params.bounds == "reinit"
            u_reinit = rng.random(X.shape) if reinit else np.empty((0, 0))
            U = pbest_trials(X, pbest, r1, XA, r2, np.ascontiguousarray(F, dtype=float),
                             np.ascontiguousarray(CR, dtype=float), u,
                             BOUNDS_IDS[self.params.bounds], self.bounds.lower,
                             self.bounds.upper, u_reinit)
        else:
            V = current_to_pbest1(X, pbest, r1, XA, r2, F[:, None])
            U = binomial_crossover(X, V, CR[:, None], rng)
            u = rng.random(U.shape) if self.params.bounds == "reinit" else None
            U = self._repair(U, X, self.bounds.lower, self.bounds.upper, u)
        n = self.trial_count()
        self._CR, self._F = CR[:n], F[:n]
        return U[:n]

    def advance(self, U: np.ndarray, fU: np.ndarray) -> None:
        n = len(U)
        X, f = self.population[:n], self.fitness[:n]
        success = fU < f
        self.archive.add(X[success], self.rng)
        delta = f[success] - fU[success]
        X_new, f_new = greedy_selection(X, f, U, fU, ties=self.ties)
        self.population[:n], self.fitness[:n] = X_new, f_new
        self.nfe += n
        self.adapt(self._CR[success], self._F[success], delta)
        self.after_generation()


@dataclasses.dataclass(frozen=True)
class JADEParams(AdaptiveDEParams):
    """JADE, ``N = ps``: ``c`` the means' learning rate, ``pbest`` from the ``max(1, round(p
    N))`` best, ``archive``: keep up to ``N`` replaced parents."""

    c: float = 0.1
    p: float = 0.05
    archive: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_unit("c", self.c)
        _check_unit("p", self.p)


class JADE(AdaptiveDE):
    """JADE: one adaptive pair (``mu_CR``, ``mu_F``) for the whole population."""

    Params = JADEParams
    label = "jade"

    def __init__(self, params: JADEParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        self._require_population("problem.ps", params.ps, params.ps)
        self.archive = Archive(params.ps if params.archive else 0, bounds.dim)
        self.mu_cr, self.mu_f = 0.5, 0.5

    def parameter_means(self, n: int) -> tuple[float, float]:
        return self.mu_cr, self.mu_f

    def pbest_counts(self, n: int) -> int:
        return min(n, max(1, round_half_up(self.params.p * n)))

    def adapt(self, S_CR: np.ndarray, S_F: np.ndarray, delta: np.ndarray) -> None:
        self.mu_cr, self.mu_f = jade_update(self.mu_cr, self.mu_f, S_CR, S_F, self.params.c)


class HistoryDE(AdaptiveDE):
    """SHADE's and L-SHADE's shared part: ``CR_i``, ``F_i`` drawn around and learnt into a
    success-history memory (``self.memory``), equal trials kept."""

    ties = True
    memory: SuccessHistory

    def parameter_means(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        return self.memory.means(self.rng, n)

    def adapt(self, S_CR: np.ndarray, S_F: np.ndarray, delta: np.ndarray) -> None:
        self.memory.update(S_CR, S_F, delta)


@dataclasses.dataclass(frozen=True)
class SHADEParams(AdaptiveDEParams):
    """SHADE, ``N = ps``, an archive of up to ``N`` parents: ``H`` memory entries, ``p_i ~
    U[2/N, p_max]``."""

    H: int = 100
    p_max: float = 0.2

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.H < 1:
            raise ConfigError("optimizer.H", self.H, "an integer >= 1")
        _check_unit("p_max", self.p_max)


class SHADE(HistoryDE):
    """SHADE: success-history memories, improvement-weighted means, random p-best fraction."""

    Params = SHADEParams
    label = "shade"

    def __init__(self, params: SHADEParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        self._require_population("problem.ps", params.ps, params.ps)
        self.archive = Archive(params.ps, bounds.dim)
        self.memory = SuccessHistory(params.H)

    def pbest_counts(self, n: int) -> np.ndarray:
        p_min = 2.0 / n
        p = self.rng.uniform(p_min, max(p_min, self.params.p_max), size=n)
        return np.minimum(np.maximum(np.floor(p * n + 0.5).astype(np.intp), 1), n)


@dataclasses.dataclass(frozen=True)
class LSHADEParams(AdaptiveDEParams):
    """L-SHADE: ``N_init`` ``ps`` (the population of every other optimizer of a comparison)
    or ``paper`` (``round(N_init_rate D)``), shrinking to ``N_min`` at the run's budget
    (``iterations`` plays no part); ``H`` memory entries; ``pbest`` from the ``max(2, round(p
    N))`` best; an archive of ``round(r_arc N)`` parents."""

    N_init: Literal["ps", "paper"] = "ps"
    N_init_rate: float = 18.0
    N_min: int = 4
    H: int = 6
    p: float = 0.11
    r_arc: float = 2.6

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.N_min < MIN_POPULATION:
            raise ConfigError("optimizer.N_min", self.N_min, f"an integer >= {MIN_POPULATION}")
        if not self.N_init_rate > 0.0:
            raise ConfigError("optimizer.N_init_rate", self.N_init_rate, "a positive number")
        if self.H < 1:
            raise ConfigError("optimizer.H", self.H, "an integer >= 1")
        _check_unit("p", self.p)
        if not self.r_arc >= 0.0:
            raise ConfigError("optimizer.r_arc", self.r_arc, "a number >= 0")


class LSHADE(HistoryDE):
    """L-SHADE: SHADE with a Lehmer CR memory, terminal CR and linear population reduction."""

    Params = LSHADEParams
    label = "lshade"

    def __init__(self, params: LSHADEParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        if params.N_init == "ps":
            n_init, key, value = params.ps, "problem.ps", params.ps
        else:
            n_init = round_half_up(params.N_init_rate * bounds.dim)
            key, value = "optimizer.N_init_rate", params.N_init_rate
        if n_init < params.N_min:
            raise ConfigError(key, value, f"an initial population of at least N_min="
                              f"{params.N_min} (it gives {n_init})")
        self._require_population(key, value, n_init)
        self.max_nfe = self.budget
        # never plan past the budget: a budget below N_init is one (cut) initial population
        self.n_init = min(n_init, self.max_nfe)
        self.archive = Archive(round_half_up(params.r_arc * self.n_init), bounds.dim)
        self.memory = SuccessHistory(params.H, lehmer_cr=True, terminal=True)

    def initial_size(self) -> int:
        return self.n_init

    def trial_count(self) -> int:
        return min(len(self.population), self.max_nfe - self.nfe)

    def pbest_counts(self, n: int) -> int:
        return min(n, max(2, round_half_up(self.params.p * n)))

    def after_generation(self) -> None:
        planned = lpsr_size(self.nfe, self.max_nfe, self.n_init, self.params.N_min)
        if planned < len(self.population):
            self.population, self.fitness = worst_removed(self.population, self.fitness,
                                                          planned)
            self.archive.resize(round_half_up(self.params.r_arc * planned), self.rng)

    @property
    def done(self) -> bool:
        return self._started and self.nfe >= self.max_nfe


#: command-line name -> optimizer class
ADAPTIVE: dict[str, type[AdaptiveDE]] = {cls.label: cls for cls in (JADE, SHADE, LSHADE)}
