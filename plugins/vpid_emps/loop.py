"""The EMPS rig in its closed loop, simulated sample by sample (numba; population-first).

**Plant** (SI units): ``M q'' = F - Fv q' - Fc sign(q') - offset`` with the motor force
``F = gtau u`` held constant over each sampling interval (the controller's zero-order hold).
Over an interval the plant is linear while the sign of ``q'`` does not change, so it is solved
exactly: ``q'(t) = v_inf + (q'_0 - v_inf) exp(-t Fv / M)`` with ``v_inf = (F - offset - Fc s) /
Fv``. Where the velocity reaches zero inside the interval the crossing time is solved exactly
too, and from rest the carriage stays at rest while ``|F - offset| <= Fc`` (static friction
holds it: the Filippov solution of the discontinuous equation, which a fine integrator with
``sign(0) = 0`` approaches by chattering) or starts in the direction of the net force. With
a constant force the velocity is monotone over an interval, so it crosses zero at most once.

**Controller** (``Simulink_EMPS_Rigide.slx`` of the data set): at sample ``k`` the position
``q_k`` is read; its two-sample mean ``qf_k = (q_k + q_{k-1}) / 2`` is differenced,
``dq_k = (qf_k - qf_{k-1}) / dt``; the voltage is ``c_k = kv (kp (qg_k - q_k) - dq_k)``.
The voltage applied over ``[t_k, t_{k+1})`` is ``sat(c_{k-d} + p_{k-d})`` with ``d`` the
controller delay in samples (the Simulink model has a unit delay, ``d = 1``; the logged voltage
matches ``d = 0``: see :mod:`.problem`), ``p`` an added pulse voltage (the validation record)
and ``sat`` the amplifier's limit of ``±vmax`` V.
"""

from __future__ import annotations

import math

import numba

_OPTS = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(inline="always", error_model="numpy")
def _from_rest(q0, net, Fv, Fc, b, tau):  # pragma: no cover - compiled
    """Position and velocity after ``tau`` s starting at rest at ``q0`` under the net force
    ``net`` (N, the motor's minus the offset)."""
    if abs(net) <= Fc:
        return q0, 0.0
    s = 1.0 if net > 0.0 else -1.0
    vinf = (net - Fc * s) / Fv
    g = -math.expm1(-b * tau)  # 1 - exp(-b tau)
    return q0 + vinf * tau - vinf * g / b, vinf * g


@numba.njit(inline="always", error_model="numpy")
def plant_step(q0, v0, net, Fv, Fc, b, h, g_h):  # pragma: no cover - compiled
    """The exact position and velocity after ``h`` s from ``(q0, v0)`` under a constant net
    force ``net`` (N); ``b = Fv / M`` (1/s), ``g_h = 1 - exp(-b h)``."""
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
    """Simulate the loop for the candidates ``P`` ``(4, n)`` (rows ``M, Fv, Fc, offset``):
    writes the position ``y[i, k]`` (m) at each sample and the applied voltage ``u_out[i, k]``
    (V) over ``[t_k, t_{k+1})``. ``qg`` ``(N,)`` the reference position (m), ``pulse`` ``(N,)``
    the voltage added to the controller's (V); the rig starts at ``q_init`` moving at
    ``v_init`` m/s, the controller's past positions on that line. ``delay``: 0 or 1 sample
    (with 1, the first sample applies its own output: there is no earlier one).

    One candidate after another, each over the whole record (its state stays in registers
    and its outputs are written in order): the plant's branches keep the compiler from
    running candidates side by side, so nothing is gained by interleaving them."""
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
