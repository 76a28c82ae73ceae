"""Richer suspension structures nested with the linear one (issue 43, item 1), per axle, on
each element's elongation ``e = J q`` (body point minus wheel, m): ``spring=cubic`` adds
``<k>_cubic`` (N/m³, force ``k e + k3 e^3``), ``damper=bilinear`` replaces ``<c>`` by
``<c>_bump`` (``e' < 0``) and ``<c>_rebound`` (N s/m). The linear structure is the model
itself (its kernel); a richer one runs RK4 at ``dt``, the road linear between samples. The
boxes and their sources: docs/suite.md, "Richer suspension structures".
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from . import linear
from .model import RideModel

#: The cubic coefficient's reference per unit of the linear rate (m⁻²): 25 % of the linear
#: force at 50 mm (a progressive or bump-stop-assisted spring).
CUBIC_PER_K = 0.25 / 0.05**2
#: Box of the cubic coefficient as multiples of ``CUBIC_PER_K x k`` (published k).
CUBIC_BOX = (0.0, 2.0)
#: Boxes of the bump and rebound coefficients as multiples of the published ``c``.
BUMP_BOX = (0.25, 1.5)
REBOUND_BOX = (0.5, 3.0)


class StructuredModel:
    """A ride model with a cubic spring and/or bilinear damper per axle (see the module)."""

    #: What the problem's ``describe()`` names as the fitted model's solver.
    fitted_solver = "RK4 (the suspension structure's nonlinear forces)"

    def __init__(self, base: RideModel, spring: str, damper: str) -> None:
        suspension = type(base).suspension
        if suspension is None:
            raise TypeError(f"{type(base).__name__} has no suspension structures")
        self.base, self.spring, self.damper, self.suspension = base, spring, damper, suspension
        springs = {k for k, _ in suspension.axles}
        dampers = {c for _, c in suspension.axles}
        names: list[str] = []
        units: list[str] = []
        for name, unit in zip(base.names, base.units, strict=True):
            if name in dampers and damper == "bilinear":
                names += [f"{name}_bump", f"{name}_rebound"]
                units += [unit, unit]
            else:
                names.append(name)
                units.append(unit)
            if name in springs and spring == "cubic":
                names.append(f"{name}_cubic")
                units.append("N/m³")
        self.names = tuple(names)
        self.units = tuple(units)
        self.sets = {key: self._set(published) for key, published in base.sets.items()}

    def __getattr__(self, name: str) -> Any:
        base = self.__dict__.get("base")
        if base is None or name.startswith("__"):  # copy and pickle probe before __init__
            raise AttributeError(name)
        return getattr(base, name)

    def _set(self, published: dict[str, float]) -> dict[str, float]:
        """A published set in this structure: the symmetric damper, the reference cubic."""
        out = dict(published)
        for k, c in self.suspension.axles:
            if self.spring == "cubic":
                out[f"{k}_cubic"] = CUBIC_PER_K * published[k]
            if self.damper == "bilinear":
                out[f"{c}_bump"] = out[f"{c}_rebound"] = out.pop(c)
        return out

    # --- parameters -----------------------------------------------------------------------
    def split(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The linear rows (bump damping), cubic coefficients (N/m³), rebound - bump (N s/m)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        col = {name: X[:, i] for i, name in enumerate(self.names)}
        lin = np.stack([col.get(name, col.get(f"{name}_bump")) for name in self.base.names],
                       axis=1)
        n, axles = X.shape[0], len(self.suspension.axles)
        k3, dc = np.zeros((n, axles)), np.zeros((n, axles))
        for a, (k, c) in enumerate(self.suspension.axles):
            if self.spring == "cubic":
                k3[:, a] = col[f"{k}_cubic"]
            if self.damper == "bilinear":
                dc[:, a] = col[f"{c}_rebound"] - col[f"{c}_bump"]
        return lin, k3, dc

    def physical(self, X: np.ndarray, known: dict[str, float]) -> np.ndarray:
        """The linear rows a vehicle, cubic coefficients ``>= 0``, damper coefficients ``> 0``."""
        lin, k3, dc = self.split(X)
        return (self.base.physical(lin, known) & np.all(np.isfinite(k3) & (k3 >= 0), axis=1)
                & np.all(np.isfinite(dc) & (lin[:, [self.base.names.index(c) for _, c in
                                                    self.suspension.axles]] + dc > 0), axis=1))

    def box(self, nominal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The base model's box for its parameters; the module's boxes for the new ones."""
        lin, _, _ = self.split(nominal[None])
        b_lo, b_hi = self.base.box(lin[0])
        lo, hi = np.empty(len(self.names)), np.empty(len(self.names))
        base_at = {name: i for i, name in enumerate(self.base.names)}
        for i, name in enumerate(self.names):
            stem, _, kind = name.rpartition("_")
            if kind == "cubic":
                ref = CUBIC_PER_K * lin[0, base_at[stem]]
                lo[i], hi[i] = CUBIC_BOX[0] * ref, CUBIC_BOX[1] * ref
            elif kind in ("bump", "rebound") and stem in base_at:
                ref = lin[0, base_at[stem]]
                box = BUMP_BOX if kind == "bump" else REBOUND_BOX
                lo[i], hi[i] = box[0] * ref, box[1] * ref
            else:
                lo[i], hi[i] = b_lo[base_at[name]], b_hi[base_at[name]]
        return lo, hi

    # --- simulation -----------------------------------------------------------------------
    def system(self, X: np.ndarray, known: dict[str, float], sensors: str
               ) -> linear.LinearSystem:
        """The linear part (the cubic term dropped, the damper at its bump value)."""
        return self.base.system(self.split(X)[0], known, sensors)

    def simulate(self, X: np.ndarray, known: dict[str, float], sensors: str, u: np.ndarray,
                 dt: float, solver: str) -> np.ndarray:
        """The ``sensors`` channels ``(n, N, p)`` by RK4 at ``dt`` from rest (any ``solver``,
        ``u`` linear between samples) of ``M q'' + C q' + K q + J^T g(J q, J q') = F u``,
        ``g = k3 e^3 + dc max(e', 0)`` per element."""
        lin, k3, dc = self.split(X)
        system = self.base.system(lin, known, sensors)
        J = self.suspension.elongations(lin, known)
        n, d = system.M.shape[0], system.dof
        r, p = system.F.shape[-1], system.Pq.shape[-2]
        Minv = np.linalg.inv(system.M)
        # q'' = G u - A q - B v - H g: the linear part and the elements' forces through M^-1
        A = Minv @ _full(system.K, n, (d, d))
        B = Minv @ _full(system.C, n, (d, d))
        G = Minv @ _full(system.F, n, (d, r))
        H = Minv @ np.swapaxes(J, 1, 2)
        u = np.ascontiguousarray(u, dtype=float)
        y = np.empty((n, u.shape[0], p))
        _rk4(np.ascontiguousarray(A), np.ascontiguousarray(B), np.ascontiguousarray(G),
             np.ascontiguousarray(H), np.ascontiguousarray(J, dtype=float),
             _full(system.Pa, n, (p, d)), _full(system.Pv, n, (p, d)),
             _full(system.Pq, n, (p, d)), _full(system.Pu, n, (p, r)),
             np.asarray(self.suspension.axle_of, dtype=np.int64),
             np.ascontiguousarray(k3, dtype=float), np.ascontiguousarray(dc, dtype=float),
             u, float(dt), y)
        return y


def _full(a: np.ndarray | None, n: int, shape: tuple[int, ...]) -> np.ndarray:
    """``a`` broadcast to ``(n, *shape)`` float64 (None: zeros)."""
    if a is None:
        return np.zeros((n, *shape))
    return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=float), (n, *shape)))


@numba.njit(cache=True, inline="always")
def _accel(c, q, v, u, k, w, A, B, G, H, J, axle_of, k3, dc, out):  # pragma: no cover
    """``out = q''`` of candidate ``c`` at the input ``(1 - w) u[k] + w u[k + 1]``."""
    d, r = A.shape[1], G.shape[2]
    for i in range(d):
        s = 0.0
        for j in range(r):
            uj = u[k, j] if w == 0.0 else (1.0 - w) * u[k, j] + w * u[k + 1, j]
            s += G[c, i, j] * uj
        for j in range(d):
            s -= A[c, i, j] * q[j] + B[c, i, j] * v[j]
        out[i] = s
    for e in range(J.shape[1]):
        el, rate = 0.0, 0.0
        for j in range(d):
            el += J[c, e, j] * q[j]
            rate += J[c, e, j] * v[j]
        a = axle_of[e]
        g = k3[c, a] * el * el * el
        if rate > 0.0:
            g += dc[c, a] * rate
        if g != 0.0:
            for i in range(d):
                out[i] -= H[c, i, e] * g


@numba.njit(cache=True)
def _rk4(A, B, G, H, J, Pa, Pv, Pq, Pu, axle_of, k3, dc, u, dt, y):  # pragma: no cover
    n, d = A.shape[0], A.shape[1]
    N, r = u.shape
    p = Pa.shape[1]
    q, v, qt, vt = np.zeros(d), np.zeros(d), np.empty(d), np.empty(d)
    a1, a2, a3, a4 = np.empty(d), np.empty(d), np.empty(d), np.empty(d)
    v2, v3 = np.empty(d), np.empty(d)
    h = 0.5 * dt
    for c in range(n):
        q[:] = 0.0
        v[:] = 0.0
        for k in range(N):
            _accel(c, q, v, u, k, 0.0, A, B, G, H, J, axle_of, k3, dc, a1)
            for o in range(p):
                s = 0.0
                for j in range(d):
                    s += Pa[c, o, j] * a1[j] + Pv[c, o, j] * v[j] + Pq[c, o, j] * q[j]
                for j in range(r):
                    s += Pu[c, o, j] * u[k, j]
                y[c, k, o] = s
            if k + 1 == N:
                break
            # stage 1: (q, v) -> (v, a1); stage 2 at the midpoint from stage 1's rates
            for j in range(d):
                qt[j] = q[j] + h * v[j]
                vt[j] = v[j] + h * a1[j]
            _accel(c, qt, vt, u, k, 0.5, A, B, G, H, J, axle_of, k3, dc, a2)
            v2[:] = vt
            for j in range(d):
                qt[j] = q[j] + h * v2[j]
                vt[j] = v[j] + h * a2[j]
            _accel(c, qt, vt, u, k, 0.5, A, B, G, H, J, axle_of, k3, dc, a3)
            v3[:] = vt
            for j in range(d):
                qt[j] = q[j] + dt * v3[j]
                vt[j] = v[j] + dt * a3[j]
            _accel(c, qt, vt, u, k, 1.0, A, B, G, H, J, axle_of, k3, dc, a4)
            for j in range(d):
                q[j] += dt / 6.0 * (v[j] + 2.0 * v2[j] + 2.0 * v3[j] + vt[j])
                v[j] += dt / 6.0 * (a1[j] + 2.0 * a2[j] + 2.0 * a3[j] + a4[j])
