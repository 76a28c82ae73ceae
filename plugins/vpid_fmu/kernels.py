"""The compiled step loops of one simulation: numba calling the binary's functions through
ctypes function pointers passed as arguments, pointers as ``size_t`` (each loop compiles once
per signature, cached, whatever binary it calls; why and how fast: docs/fmu.md). Each writes
the outputs ``y`` ``(N, p)`` at the times ``t`` (``y[0]`` is the caller's) and returns
``(status, k)``: the first status above warning (2 discard, 3 error, 4 fatal) and its
sample, or ``(0, N)``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Dormand–Prince 5(4) tableau (the ``solver=dopri5`` of model exchange).
_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0.0],
    [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
])
_B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0])
_E = _B - np.array([5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100,
                    1 / 40])
#: The tableau ``(A, B, E, C)`` as :func:`me2_dopri5` takes it.
TABLEAU = (_A, _B, _E, _C)


@njit(cache=True)
def cs2_derivatives(do_step, set_real, set_der, get_real, c, t, u, vr_in, vr_out, order, y):
    """FMI 2.0 co-simulation given each input's slope (the input linear between samples)."""
    n, r = u.shape
    p = vr_out.size
    du = np.empty(r)
    pu, py, pdu = u.ctypes.data, y.ctypes.data, du.ctypes.data
    pin, pout, pord = vr_in.ctypes.data, vr_out.ctypes.data, order.ctypes.data
    for k in range(n - 1):
        h = t[k + 1] - t[k]
        for j in range(r):
            du[j] = (u[k + 1, j] - u[k, j]) / h
        s = set_real(c, pin, r, pu + 8 * r * k)
        if s > 1:
            return s, k
        s = set_der(c, pin, r, pord, pdu)
        if s > 1:
            return s, k
        s = do_step(c, t[k], h, 1)
        if s > 1:
            return s, k
        s = set_real(c, pin, r, pu + 8 * r * (k + 1))
        if s > 1:
            return s, k
        s = get_real(c, pout, p, py + 8 * p * (k + 1))
        if s > 1:
            return s, k
    return 0, n


@njit(cache=True)
def cs2_hold(do_step, set_real, get_real, c, t, u, substeps, vr_in, vr_out, y):
    """FMI 2.0 co-simulation, the input held (linearly interpolated) over each sub-step."""
    n, r = u.shape
    p = vr_out.size
    v = np.empty(r)
    pu, py, pv = u.ctypes.data, y.ctypes.data, v.ctypes.data
    pin, pout = vr_in.ctypes.data, vr_out.ctypes.data
    for k in range(n - 1):
        h = (t[k + 1] - t[k]) / substeps
        for i in range(substeps):
            w = i / substeps
            for j in range(r):
                v[j] = u[k, j] + w * (u[k + 1, j] - u[k, j])
            s = set_real(c, pin, r, pv)
            if s > 1:
                return s, k
            s = do_step(c, t[k] + i * h, h, 1)
            if s > 1:
                return s, k
        s = set_real(c, pin, r, pu + 8 * r * (k + 1))
        if s > 1:
            return s, k
        s = get_real(c, pout, p, py + 8 * p * (k + 1))
        if s > 1:
            return s, k
    return 0, n


@njit(cache=True)
def cs3_hold(do_step, set_real, get_real, c, t, u, substeps, vr_in, vr_out, y, flags):
    """FMI 3.0 co-simulation, the input held over sub-steps as :func:`cs2_hold` (FMI 3.0 has
    no input derivatives). ``flags``: 4 bytes for ``fmi3DoStep``'s booleans and a float64
    for its last successful time (``flags[0:4]``, ``flags[8:16]``)."""
    n, r = u.shape
    p = vr_out.size
    v = np.empty(r)
    pu, py, pv = u.ctypes.data, y.ctypes.data, v.ctypes.data
    pin, pout = vr_in.ctypes.data, vr_out.ctypes.data
    base = flags.ctypes.data
    for k in range(n - 1):
        h = (t[k + 1] - t[k]) / substeps
        for i in range(substeps):
            w = i / substeps
            for j in range(r):
                v[j] = u[k, j] + w * (u[k + 1, j] - u[k, j])
            s = set_real(c, pin, r, pv, r)
            if s > 1:
                return s, k
            s = do_step(c, t[k] + i * h, h, True, base, base + 1, base + 2, base + 8)
            if s > 1:
                return s, k
            if flags[1] != 0:  # terminateSimulation
                return 3, k
        s = set_real(c, pin, r, pu + 8 * r * (k + 1), r)
        if s > 1:
            return s, k
        s = get_real(c, pout, p, py + 8 * p * (k + 1), p)
        if s > 1:
            return s, k
    return 0, n


@njit(cache=True)
def _me2_rhs(set_time, set_real, set_states, get_der, c, t, x, v, vr_in, dx):
    s = set_time(c, t)
    if s > 1:
        return s
    s = set_real(c, vr_in.ctypes.data, v.size, v.ctypes.data)
    if s > 1:
        return s
    s = set_states(c, x.ctypes.data, x.size)
    if s > 1:
        return s
    return get_der(c, dx.ctypes.data, dx.size)


@njit(cache=True)
def _input_at(t, u, k, tau, v):
    """The record's input at ``tau`` in ``[t[k], t[k+1]]``, linear between samples."""
    w = (tau - t[k]) / (t[k + 1] - t[k])
    for j in range(u.shape[1]):
        v[j] = u[k, j] + w * (u[k + 1, j] - u[k, j])


@njit(cache=True)
def me2_dopri5(fns, c, t, u, x, vr_in, vr_out, y, rtol, atol, tables):
    """FMI 2.0 model exchange by Dormand–Prince 5(4) (a step accepted when the rms of
    ``|e_i| / (atol + rtol max(|x_i|, |x_new_i|))`` is at most 1), the input linear between
    samples, every sample time hit. ``x``: the states at ``t[0]``. Status 5: the FMU asked
    for an event (not supported); 6: the step fell below ``1e-14`` of the span."""
    set_time, set_real, set_states, get_der, get_real, completed = fns
    A, B, E, C = tables
    n, r = u.shape
    nx = x.size
    K = np.empty((7, nx))
    xs = np.empty(nx)
    xn = np.empty(nx)
    v = np.empty(r)
    buf = np.empty(vr_out.size)
    flags = np.zeros(2, dtype=np.int32)
    span = t[-1] - t[0]
    h = min(t[1] - t[0], 1e-3 * span) if n > 1 else 0.0
    _input_at(t, u, 0, t[0], v)
    s = _me2_rhs(set_time, set_real, set_states, get_der, c, t[0], x, v, vr_in, K[0])
    if s > 1:
        return s, 0
    for k in range(n - 1):
        tk = t[k]
        while tk < t[k + 1]:
            last = tk + h >= t[k + 1] - 1e-12 * span
            hs = t[k + 1] - tk if last else h
            for stage in range(1, 7):
                for i in range(nx):
                    acc = 0.0
                    for m in range(stage):
                        acc += A[stage, m] * K[m, i]
                    xs[i] = x[i] + hs * acc
                ts = tk + C[stage] * hs
                _input_at(t, u, k, min(ts, t[k + 1]), v)
                s = _me2_rhs(set_time, set_real, set_states, get_der, c, ts, xs, v, vr_in,
                             K[stage])
                if s > 1:
                    return s, k
            err = 0.0
            for i in range(nx):
                acc, e = 0.0, 0.0
                for m in range(7):
                    acc += B[m] * K[m, i]
                    e += E[m] * K[m, i]
                xn[i] = x[i] + hs * acc
                sc = atol + rtol * max(abs(x[i]), abs(xn[i]))
                err += (hs * e / sc) ** 2
            err = np.sqrt(err / nx)
            if err <= 1.0:
                tk = t[k + 1] if last else tk + hs
                x[:] = xn
                K[0] = K[6]  # first same as last: the derivative at the new point
                s = completed(c, 1, flags.ctypes.data, flags.ctypes.data + 4)
                if s > 1:
                    return s, k
                if flags[0] != 0 or flags[1] != 0:
                    return 5, k
                fac = 5.0 if err == 0.0 else min(5.0, 0.9 * err ** -0.2)
                # a step cut short to land on the sample does not shrink the next one
                h = max(h, hs * fac) if last and hs < h else hs * fac
            else:
                h = 0.1 * hs if not np.isfinite(err) else hs * max(0.2, 0.9 * err ** -0.2)
                if h < 1e-14 * span:
                    return 6, k
        # the outputs at the sample: states, time and the sample's input set, then read
        _input_at(t, u, k, t[k + 1], v)
        s = _me2_rhs(set_time, set_real, set_states, get_der, c, t[k + 1], x, v, vr_in, K[0])
        if s > 1:
            return s, k
        s = get_real(c, vr_out.ctypes.data, vr_out.size, buf.ctypes.data)
        if s > 1:
            return s, k
        y[k + 1] = buf
    return 0, n
