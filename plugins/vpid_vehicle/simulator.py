"""One way of computing the body accelerations on a time grid (integrator, step, sampling):
the model's and the reference's, which differ when the user studies the "inverse crime"
(``problem.reference.*``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .model import KnownConstants, physical
from .objective import objective
from .road import Bump, sample, time_grid


@dataclass(frozen=True)
class Simulator:
    """z1'' and z2'' (m/s^2) on ``t_k = k dt``, ``k = 0 ... floor(T / dt)`` (s); ``sampling``
    matters for Newmark only; ``stride`` keeps every stride-th sample (a reference computed
    at a finer step lands on the model's grid)."""

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
    #: Threads a large batch may use (see :meth:`set_threads`); never changes a result.
    threads: int = field(init=False, default=1, compare=False)
    _setup: Any = field(init=False, default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        t = time_grid(self.T, self.dt)
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "y", sample(self.bump, t, self.sampling, self.gamma))

    def set_threads(self, n: int) -> None:
        """Let the kernel spread a large batch over ``n`` threads (bit-identical results)."""
        object.__setattr__(self, "threads", int(n))

    def _kernel_setup(self) -> Any:
        """The kernel's :class:`~vpid_vehicle.kernel.Setup` for this grid, made on first use."""
        if self._setup is None:
            from . import kernel

            k = self.known
            object.__setattr__(self, "_setup", kernel.Setup(k.L, k.kt1, k.kt2, self.y, self.dt,
                                                            self.gamma, self.beta))
        return self._setup

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
            out = self._kernel_setup().responses(X, self.threads)
        return out if self.stride == 1 else out[:, :, :: self.stride]

    def objective(self, X: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """Eq. (3) of the rows of ``X``, inf where one fails (compiled for Newmark at stride 1)."""
        if self.integrator == "newmark" and self.stride == 1:
            return self._kernel_setup().objective(X, reference, self.threads)
        X = np.atleast_2d(np.asarray(X, dtype=float))
        f = np.full(X.shape[0], np.inf)
        ok = physical(X, self.known)
        if np.any(ok):
            with np.errstate(all="ignore"):
                f[ok] = objective(self(X[ok]), reference)
        return f

    def objective_rows(self, X: np.ndarray, references: np.ndarray,
                       index: np.ndarray) -> np.ndarray:
        """Eq. (3) of row ``j`` against ``references[index[j]]`` (runs in lockstep)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        index = np.asarray(index, dtype=np.int64).reshape(-1)
        if self.integrator == "newmark" and self.stride == 1:
            return self._kernel_setup().objective_rows(X, references, index, self.threads)
        f = np.empty(X.shape[0])
        for m in np.unique(index):
            rows = np.flatnonzero(index == m)
            f[rows] = self.objective(X[rows], references[m])
        return f
