"""Exact response of the linear model to the rectangular bump (validation solver): ``s =
[q, q']``, ``s' = A s + B y``; each step split at the bump edges inside it and every piece
propagated exactly (the input is piecewise constant) by the exponential of ``[[A, B], [0, 0]]
tau``, once per distinct piece length for the whole population. Exact to round-off at the
samples (the body accelerations do not depend on the input directly).
"""

from __future__ import annotations

import numpy as np

from .model import KnownConstants, matrices, response_rows, tyre_input
from .road import TIME_TOL, Bump


def body_accelerations(
    X: np.ndarray, known: KnownConstants, bump: Bump, t: np.ndarray
) -> np.ndarray:
    """Exact z1'', z2'' (m/s^2) ``(n, 2, len(t))`` at the times ``t`` (s), at rest at t = 0."""
    from scipy.linalg import expm  # lazy: keeps the plugin's import chain light

    M, C, K = matrices(X, known)
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    aug = np.zeros((n, 10, 10))
    aug[:, :4, 4:8] = np.eye(4)
    aug[:, 4:8, :4] = -Minv @ K
    aug[:, 4:8, 4:8] = -Minv @ C
    aug[:, 4:8, 8:] = Minv @ tyre_input(known)
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def propagator(tau: float) -> tuple[np.ndarray, np.ndarray]:
        key = round(tau, 12)
        if key not in cache:
            E = expm(aug * tau)
            cache[key] = (E[:, :8, :8], E[:, :8, 8:])
        return cache[key]

    s = np.zeros((n, 8))
    states = np.empty((len(t), n, 8))
    states[0] = s
    for k in range(1, len(t)):
        t0, t1 = float(t[k - 1]), float(t[k])  # cut at the bump edges inside the step
        cuts = [t0, *(e for e in sorted(bump.edges) if t0 + TIME_TOL < e < t1 - TIME_TOL), t1]
        for a, b in zip(cuts[:-1], cuts[1:], strict=True):
            Phi, Gamma = propagator(b - a)
            y = bump.value(np.array([0.5 * (a + b)]))[0]
            s = np.einsum("nij,nj->ni", Phi, s) + Gamma @ y
        states[k] = s
    # acceleration = -M^-1 (K q + C q') (+ M^-1 B_y y, zero in the body rows)
    acc = -(np.einsum("nij,knj->kni", Minv @ K, states[..., :4])
            + np.einsum("nij,knj->kni", Minv @ C, states[..., 4:]))
    return np.einsum("nij,knj->nik", response_rows(X, known), acc)
