"""One simulation core for linear systems driven by road inputs (SI units; docs/suite.md):
``M q'' + C q' + K q = F u(t)`` per candidate, from rest, outputs ``y = Pa q'' + Pv q' + Pq q
+ Pu u``, discretised as ``x_{k+1} = A x_k + U u_k + V u_{k+1}``, ``y_k = Ox x_k + Ou u_k`` on
``x = [q, q']`` by :func:`newmark` (the fitted model) or :func:`exact_foh` (the record);
:func:`simulate` iterates either; :func:`newmark_outputs`, the fitted model's path, is
compiled end to end (the table per candidate, then :mod:`.codegen`'s loops).
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class LinearSystem:
    """``n`` linear systems with ``d`` degrees of freedom, ``r`` inputs, ``p`` outputs."""

    M: np.ndarray  # (n, d, d) mass matrix, kg (or kg m^2)
    C: np.ndarray  # (n, d, d) damping matrix, N s/m
    K: np.ndarray  # (n, d, d) stiffness matrix, N/m
    F: np.ndarray  # (n, d, r) input map: force per unit of each input channel
    Pa: np.ndarray  # (p, d) or (n, p, d) outputs from accelerations
    Pq: np.ndarray  # (p, d) or (n, p, d) outputs from displacements
    Pu: np.ndarray  # (p, r) or (n, p, r) outputs from the inputs
    Pv: np.ndarray | None = None  # (p, d) or (n, p, d) outputs from velocities (None: 0)

    @property
    def dof(self) -> int:
        return self.M.shape[-1]

    def continuous(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(Ac, Bc, Ox, Ou)``: ``x' = Ac x + Bc u`` and ``y = Ox x + Ou u``, batched."""
        n, d = self.M.shape[0], self.dof
        Minv = np.linalg.inv(self.M)
        G = -np.concatenate([Minv @ self.K, Minv @ self.C], axis=2)  # a = G x + H u
        H = Minv @ self.F
        Ac = np.zeros((n, 2 * d, 2 * d))
        Ac[:, :d, d:] = np.eye(d)
        Ac[:, d:, :] = G
        Bc = np.concatenate([np.zeros_like(H), H], axis=1)
        p = self.Pq.shape[-2]
        Pv = np.zeros((n, p, d)) if self.Pv is None else np.broadcast_to(self.Pv, (n, p, d))
        Ox = self.Pa @ G + np.concatenate([np.broadcast_to(self.Pq, (n, p, d)), Pv], axis=2)
        Ou = self.Pa @ H + self.Pu
        return Ac, Bc, Ox, Ou


def newmark(system: LinearSystem, dt: float, gamma: float = 0.5, beta: float = 0.25
            ) -> tuple[np.ndarray, ...]:
    """``(A, U, V, Ox, Ou)`` of Newmark-beta's step at ``dt`` s (see the module docstring)."""
    M, C, K, F = system.M, system.C, system.K, system.F
    d = system.dof
    Ac, Bc, Ox, Ou = system.continuous()
    eye = np.eye(d)
    G, H = Ac[:, d:, :], Bc[:, d:, :]  # a = G x + H u
    # predictor [q_p; v_p] = P x_k + Q u_k
    base = np.block([[eye, dt * eye], [np.zeros((d, d)), eye]])
    pred = np.concatenate([(0.5 - beta) * dt**2 * eye, (1.0 - gamma) * dt * eye], axis=0)
    P = base + pred @ G
    Q = pred @ H
    # corrector: a_{k+1} = S^-1 (F u_{k+1} - [K C] pred), x_{k+1} = pred + D a_{k+1}
    Sinv = np.linalg.inv(M + gamma * dt * C + beta * dt**2 * K)
    D = np.concatenate([beta * dt**2 * eye, gamma * dt * eye], axis=0)
    KC = np.concatenate([K, C], axis=2)
    T = np.eye(2 * d) - D @ Sinv @ KC
    return T @ P, T @ Q, D @ Sinv @ F, Ox, Ou


def exact_foh(system: LinearSystem, dt: float) -> tuple[np.ndarray, ...]:
    """``(A, U, V, Ox, Ou)`` of the exact solution over ``dt`` s for an input linear between
    samples: ``exp(dt [[Ac, Bc, 0], [0, 0, I], [0, 0, 0]])`` gives ``x_{k+1} = E11 x_k + E12
    u_k + E13 (u_{k+1} - u_k) / dt``."""
    from scipy.linalg import expm

    Ac, Bc, Ox, Ou = system.continuous()
    n, s = Ac.shape[:2]
    r = Bc.shape[2]
    big = np.zeros((n, s + 2 * r, s + 2 * r))
    big[:, :s, :s] = Ac
    big[:, :s, s:s + r] = Bc
    big[:, s:s + r, s + r:] = np.eye(r)
    E = expm(big * dt)
    E11, E12, E13 = E[:, :s, :s], E[:, :s, s:s + r], E[:, :s, s + r:]
    return E11, E12 - E13 / dt, E13 / dt, Ox, Ou


def simulate(step: tuple[np.ndarray, ...], u: np.ndarray) -> np.ndarray:
    """The outputs ``(n, N, p)`` of ``step = (A, U, V, Ox, Ou)`` driven by ``u`` from rest."""
    from .kernel import run  # compiled: imported on first use
    A, U, V, Ox, Ou = (np.ascontiguousarray(np.moveaxis(np.asarray(a, dtype=float), 0, -1))
                       for a in step)
    u = np.ascontiguousarray(u, dtype=float)
    y = np.empty((Ox.shape[0], u.shape[0], A.shape[2]))
    run(A, U, V, Ox, Ou, u, y)
    return y.transpose(2, 1, 0)


def _leading(a: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray:
    """``a`` (float64) with a leading batch axis, ``1`` when shared; None: zeros of ``shape``."""
    if a is None:
        return np.zeros((1, *shape))
    a = np.asarray(a, dtype=float)
    return a if a.ndim == len(shape) + 1 else a[None]


def newmark_outputs(system: LinearSystem, dt: float, u: np.ndarray, gamma: float = 0.5,
                    beta: float = 0.25) -> np.ndarray:
    """The outputs ``(n, N, p)`` of Newmark-beta at ``dt`` s driven by ``u`` ``(N, r)`` from
    rest: ``simulate(newmark(system, dt, gamma, beta), u)`` to rounding, compiled."""
    from . import kernel
    from .codegen import runs

    n, d = system.M.shape[0], system.dof
    r, p = system.F.shape[-1], system.Pq.shape[-2]
    u = np.ascontiguousarray(u, dtype=float)
    T, w0 = np.empty((n, 2 * d + p, 2 * d + r)), np.empty((n, 2 * d))
    kernel.newmark_table(
        _leading(system.M, (d, d)), _leading(system.C, (d, d)), _leading(system.K, (d, d)),
        _leading(system.F, (d, r)), _leading(system.Pa, (p, d)), _leading(system.Pv, (p, d)),
        _leading(system.Pq, (p, d)), _leading(system.Pu, (p, r)),
        float(dt), float(gamma), float(beta), u[0], T, w0)
    y = np.empty((p, u.shape[0], n))
    runs().get((2 * d, p, r), kernel.run_table_loops)(T, w0, u, y)
    return y.transpose(2, 1, 0)


def undamped_frequencies_hz(M: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Undamped natural frequencies (Hz, ascending) of one system: ``eig(K, M)``."""
    from scipy.linalg import eigh

    w2 = eigh(K, M, eigvals_only=True)
    return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi)
