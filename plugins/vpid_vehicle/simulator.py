"""One way of computing the body accelerations on a time grid: integrator, step, sampling.

The model and the reference each get a :class:`Simulator`; they differ when the user studies
the "inverse crime" (``problem.reference.*``). The Newmark path runs the compiled kernel,
imported on first use; if numba is missing it falls back to the plain numpy Newmark.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .model import KnownConstants, physical
from .objective import objective
from .road import Bump, sample, time_grid


@dataclass(frozen=True)
class Simulator:
    """Computes z1'' and z2'' (m/s^2) on ``t_k = k dt``, ``k = 0 ... floor(T / dt)``.

    ``T``, ``dt`` in s; ``integrator`` is ``newmark`` or ``exact``; ``sampling`` (``point`` or
    ``average``) only matters for Newmark; ``stride`` keeps every stride-th sample, so a
    reference computed at a finer step lands on the model's grid.
    """

    known: KnownConstants
    bump: Bump
    T: float
    dt: float
    integrator: str = "newmark"
    sampling: str = "point"
    gamma: float = 0.5
    beta: float = 0.25
    stride: int = 1
    t: np.ndarray = field(init=False, repr=False)
    y: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        t = time_grid(self.T, self.dt)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "y", sample(self.bump, t, self.sampling, self.gamma))

    @property
    def t_out(self) -> np.ndarray:
        """Times of the returned samples (s)."""
        return self.t[:: self.stride]

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """Responses of the rows of ``X`` (physical units), shape ``(n, 2, len(t_out))``."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if self.integrator == "exact":
            from .exact import body_accelerations as exact_acc

            out = exact_acc(X, self.known, self.bump, self.t)
        else:
            out = newmark_fast(X, self.known, self.y, self.dt, self.gamma, self.beta)
        return out[:, :, :: self.stride]


    def objective(self, X: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """Eq. (3) of the rows of ``X`` against ``reference`` (2, N), inf where a candidate is
        non-physical or its simulation fails. Newmark with stride 1 runs fully compiled."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if self.integrator == "newmark" and self.stride == 1:
            kernel = _kernel()
            if kernel is not None:
                k = self.known
                return kernel.evaluate(X, k.L, k.kt1, k.kt2, self.y, self.dt, self.gamma,
                                       self.beta, reference)
        f = np.full(X.shape[0], np.inf)
        ok = physical(X, self.known)
        if np.any(ok):
            with np.errstate(all="ignore"):
                f[ok] = objective(self(X[ok]), reference)
        return f


def _kernel():
    """The compiled kernel module, or None when numba cannot be imported."""
    try:
        from . import kernel
    except ImportError:  # pragma: no cover - numba is a dependency
        return None
    return kernel


def newmark_fast(
    X: np.ndarray, known: KnownConstants, y: np.ndarray, dt: float, gamma: float, beta: float
) -> np.ndarray:
    """The compiled kernel (plain numpy Newmark if numba cannot be imported)."""
    kernel = _kernel()
    if kernel is None:  # pragma: no cover - numba is a dependency
        from .newmark import body_accelerations as plain

        return plain(X, known, y, dt, gamma, beta)
    return kernel.body_accelerations(X, known.L, known.kt1, known.kt2, y, dt, gamma, beta)
