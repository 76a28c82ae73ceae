"""The EMPS rig in its closed loop, simulated sample by sample (numba).

**Plant** (SI units): ``M q'' = F - Fv q' - Fc sign(q') - offset``, the motor force ``F = gtau
u`` held over each interval, solved exactly: ``q'(t) = v_inf + (q'_0 - v_inf) exp(-t Fv / M)``,
``v_inf = (F - offset - Fc s) / Fv``, while the sign ``s`` of ``q'`` holds (the velocity is
monotone, so it crosses zero at most once, at a time solved for); from rest the carriage stays
while ``|F - offset| <= Fc`` (the Filippov solution a fine integrator approaches by chattering).

**Controller** (``Simulink_EMPS_Rigide.slx``): ``qf_k = (q_k + q_{k-1}) / 2``, ``dq_k = (qf_k -
qf_{k-1}) / dt``, ``c_k = kv (kp (qg_k - q_k) - dq_k)``; applied over ``[t_k, t_{k+1})``:
``sat(c_{k-d} + p_{k-d})`` (``d`` the controller delay, ``p`` the pulse voltage, ``sat`` the
amplifier's ``±vmax`` V).
"""

from __future__ import annotations

import math

import numba

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(inline="always", error_model="numpy")
def _from_rest(q0, net, Fv, Fc, b, tau):  # pragma: no cover - compiled
    """Position and velocity after ``tau`` s from rest at ``q0`` under the net force ``net`` (N)."""
    if abs(net) <= Fc:
        return q0, 0.0
    s = 1.0 if net > 0.0 else -1.0
    vinf = (net - Fc * s) / Fv
    g = -math.expm1(-b * tau)  # 1 - exp(-b tau)
    return q0 + vinf * tau - vinf * g / b, vinf * g


@numba.njit(inline="always", error_model="numpy")
def plant_step(q0, v0, net, Fv, Fc, b, h, g_h):  # pragma: no cover - compiled
    """Exact position and velocity after ``h`` s under a constant net force ``net`` (N)."""
    if v0 == 0.0:
        return _from_rest(q0, net, Fv, Fc, b, h)
    s = 1.0 if v0 > 0.0 else -1.0
    vinf = (net - Fc * s) / Fv
    v1 = v0 + (vinf - v0) * g_h
    if v1 * s > 0.0:
        return q0 + vinf * h + (v0 - vinf) * g_h / b, v1
    # The velocity reaches zero at tc (vinf has the opposite sign of v0 here).
    tc = math.log1p(-v0 / vinf) / b  # exp(-b tc) = vinf / (vinf - v0)
    tc = min(max(tc, 0.0), h)
    qc = q0 + vinf * tc + v0 / b
    return _from_rest(qc, net, Fv, Fc, b, h - tc)


@numba.njit(**_OPTS)
def closed_loop(P, qg, pulse, q_init, v_init, gtau, kp, kv, vmax, dt, delay, y,
                u_out):  # pragma: no cover - compiled
    """The loop for the candidates ``P`` ``(4, n)`` (``M, Fv, Fc, offset``): the position
    ``y[i, k]`` (m) and the applied voltage ``u_out[i, k]`` (V); ``qg`` the reference (m),
    ``pulse`` the added voltage (V); from ``q_init`` at ``v_init`` m/s (the controller's past
    on that line). ``delay`` 1: the first sample applies its own output. One candidate after
    another: the plant's branches keep the compiler from interleaving them anyway."""
    n, N = P.shape[1], qg.shape[0]
    for i in range(n):
        M, Fv, Fc, offset = P[0, i], P[1, i], P[2, i], P[3, i]
        b = Fv / M
        g_h = -math.expm1(-b * dt)
        q, v = q_init, v_init
        q_prev, qf_prev = q_init - v_init * dt, q_init - 1.5 * v_init * dt
        c_prev = 0.0
        for k in range(N):
            y[i, k] = q
            qf = 0.5 * (q + q_prev)
            c = kv * (kp * (qg[k] - q) - (qf - qf_prev) / dt) + pulse[k]
            qf_prev, q_prev = qf, q
            applied = c if delay == 0 or k == 0 else c_prev
            c_prev = c
            applied = min(max(applied, -vmax), vmax)
            u_out[i, k] = applied
            q, v = plant_step(q, v, gtau * applied - offset, Fv, Fc, b, dt, g_h)
