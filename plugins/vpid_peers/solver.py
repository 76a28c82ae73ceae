"""A bounded trust-region (Levenberg-Marquardt) descent on ``F = sum_g ||r_g||`` (the
vehicle's Eq. 3 up to a factor), from ``evaluate(X) -> (f, R)`` on physical rows: the point
and its forward-difference neighbours as ONE batch, then ONE trial row per iteration, the
damped IRLS step inside the box (:mod:`vpid_peers.sumofnorms`), Broyden's updates between
finite-difference Jacobians (docs/peers.md, "optimizer=lsq").
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from .coordinates import Coordinates
from .sumofnorms import LocalModel, box_step, sum_of_norms

Evaluate = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclasses.dataclass(frozen=True)
class SolverSettings:
    """``fd_step``, ``inner``, ``broyden``, ``ftol``: ``optimizer=lsq``'s keys
    (docs/peers.md); ``refresh``: a fresh Jacobian after this many updates (0: when a step
    fails)."""

    fd_step: float = 1e-7
    inner: int = 1
    broyden: bool = True
    refresh: int = 0
    ftol: float = 1e-10
    max_iter: int = 1000


@dataclasses.dataclass
class Descent:
    """Where a descent ended (``u`` in solver coordinates), after how many iterations, why."""

    u: np.ndarray
    F: float
    r: np.ndarray
    iterations: int
    reason: str


class Solver:
    """Descents of ``F = sum_g ||r_g||`` over a box, every evaluation through ``evaluate``."""

    def __init__(
        self,
        evaluate: Evaluate,
        coordinates: Coordinates,
        groups: np.ndarray,
        settings: SolverSettings = SolverSettings(),
    ) -> None:
        self.evaluate = evaluate
        self.coords = coordinates
        self.groups = np.asarray(groups, dtype=int).reshape(-1)
        self.n_groups = int(self.groups.max()) + 1 if self.groups.size else 1
        self.settings = settings

    def _residuals(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        _, R = self.evaluate(self.coords.to_x(np.atleast_2d(U)))
        R = np.asarray(R, dtype=float)
        return sum_of_norms(R, self.groups, self.n_groups), R

    def jacobian(
        self, u: np.ndarray, r: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """``(J, r, F)``: the forward-difference ``dr/du`` at ``u``, asked as one batch."""
        n = u.size
        h = np.full(n, self.settings.fd_step)
        h = np.where(u + h > self.coords.upper, -h, h)
        U = u + np.diag(h)
        if r is None:
            F, R = self._residuals(np.vstack([u, U]))
            F0, r, R = float(F[0]), R[0], R[1:]
        else:
            _, R = self._residuals(U)
            F0 = float(sum_of_norms(r[None], self.groups, self.n_groups)[0])
        J = (R - r).T / h
        return J, r, F0

    def _step(self, model: LocalModel, u: np.ndarray, lam: float) -> np.ndarray:
        lower, upper = self.coords.lower - u, self.coords.upper - u
        p = np.zeros(u.size)
        for _ in range(max(1, self.settings.inner)):
            H, g = model.irls_system(p)
            scale = np.maximum(np.diag(H), 1e-12 * max(float(np.max(np.diag(H))), 1e-300))
            p = box_step(H, g, lam * scale, lower, upper)
        return p

    def descend(self, u0: np.ndarray, r0: np.ndarray | None = None) -> Descent:
        """One descent from ``u0`` until it converges (see the module docstring)."""
        s = self.settings
        u = np.clip(np.asarray(u0, dtype=float), self.coords.lower, self.coords.upper)
        J, r, F = self.jacobian(u, r0)
        if not np.isfinite(F) or not np.all(np.isfinite(J)):
            return Descent(u, F, r, 0, "not finite")
        fresh, updates = True, 0
        lam, nu = 1e-3, 2.0
        for it in range(1, s.max_iter + 1):
            model = LocalModel(r, J, self.groups, self.n_groups)
            p = self._step(model, u, lam)
            pred = model.value(np.zeros(u.size)) - model.value(p)
            if not pred > s.ftol * F:
                if fresh:
                    return Descent(u, F, r, it, "converged")
                J, r, F = self.jacobian(u, r)
                fresh, updates = True, 0
                continue
            u_trial = np.clip(u + p, self.coords.lower, self.coords.upper)
            F_trial, R_trial = self._residuals(u_trial)
            F_trial, r_trial = float(F_trial[0]), R_trial[0]
            finite = np.isfinite(F_trial) and np.all(np.isfinite(r_trial))
            was_fresh = fresh
            if s.broyden and finite:
                step = u_trial - u
                J = J + np.outer(r_trial - r - J @ step, step) / (step @ step)
                fresh, updates = False, updates + 1
            rho = (F - F_trial) / pred if finite else -np.inf
            if rho > 1e-4:
                u, r, F = u_trial, r_trial, F_trial
                lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
                nu = 2.0
                if not s.broyden:
                    J, _, _ = self.jacobian(u, r)
                    fresh = True
            elif not was_fresh:
                J, r, F = self.jacobian(u, r)  # a failed step with an updated Jacobian
                fresh, updates = True, 0
            else:
                lam *= nu
                nu *= 2.0
            if s.refresh and updates >= s.refresh:
                J, r, F = self.jacobian(u, r)
                fresh, updates = True, 0
        return Descent(u, F, r, s.max_iter, "max_iter")
