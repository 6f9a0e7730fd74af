r"""The hydraulic rung's formulas, each once, as plain Python on floats (numba compiles them as
they are, like :mod:`drs_model.kernels`).

State ``y = (psi3, psi3', x_A, x_B, x_v)``: the flap angle [rad] and rate [rad/s] (the rigid
mechanism in its regular coordinate, :func:`drs_model.kernels.psi3_acceleration`), the chamber
states of the piston-side (A) and rod-side (B) chambers [Pa], and the normalised spool position.
A chamber's state is its pressure while the chamber is full; below the vapour pressure ``p_v`` it
measures the vapour cavity instead (:func:`chamber_pressure`, :func:`cavity_volume`):

.. math::

    p = \max(x, p_v), \qquad V_{cav} = V \, (p_v - x) / \beta_e(p_v) \quad (x < p_v)

Equations (Merritt, "Hydraulic Control Systems"; ``s`` and ``s' = u_s psi3'`` from the psi3
kinematics):

.. math::

    V_A = V_{A0} + A_A (s - s_{min}), \quad V_B = V_{B0} + A_B (s_{max} - s)

    \dot x = \frac{\beta_e(\max(x, p_v))}{V} (Q_{in} - \dot V)
             + [x < p_v] \frac{\dot V}{V} (p_v - x)

    Q_{A,in} = Q_A - Q_{AB} - Q_{A,ext} - Q_{A,relief}, \quad
    Q_{B,in} = Q_B + Q_{AB} - Q_{B,ext} - Q_{B,relief}

    F = p_A A_A - p_B A_B - F_{friction}(\dot s) + F_{stop}(s, \dot s)

    \ddot\psi_3 = \psi_3''(\psi_3, \dot\psi_3, F), \qquad
    \dot x_v = (u - x_v) / \tau_v \quad (x_v = u \text{ when } \tau_v = 0)

Above the vapour pressure the chamber equation is continuity, ``p' = beta_e / V (Q_in - V')``;
below it the cavity takes the volume the oil does not fill (``V_cav' = V' - Q_in``, the pressure
held at ``p_v``). The cavity is measured on the mixture's modulus at the floor,
``beta_e(p_v)`` (:func:`cavity_modulus`; ``beta`` without air), so that the state and its rate
are both continuous through ``x = p_v`` (only the rate's slope changes there): a step that
crosses the floor, either way, carries no rate from the other side. (Measured on the oil's
``beta``, 1.4e5 times ``beta_e(p_v)`` with the default air, a step crossing upward would keep
the cavity's fast rate past the crossing and overshoot, and the free air, whose volume goes as
``1/p``, would lose more volume than the cavity held.) The effective bulk
modulus of the oil with its entrained air (:func:`effective_bulk_modulus`, the model and its
sources in :mod:`~drs_model.fidelity.hydraulic_params`), with ``phi = a (p_sat / p)^(1/n)`` the
free air per volume of oil:

.. math::

    \beta_e(p) = \beta \, \frac{1 + \phi}{1 + \beta \phi / (n p)}

The valve's four metering edges (P->A and B->T open for ``x_v > 0``, P->B and A->T for
``x_v < 0``) each pass ``Q = k x dp / sqrt(|dp| + p_lam)``: the turbulent orifice law
``k x sign(dp) sqrt(|dp|)`` above ``p_lam``, laminar (linear) below it, smooth through zero.
The linear law (the ideal valve) passes ``k_q x`` whatever the pressures. The servo loop: in
stroke mode ``u = K_ff v_ref A_A / Q_nl + K_p (s_ref - s)``, in force mode
``u = K_f (F_ref - (p_A A_A - p_B A_B))``, clipped to [-1, 1].
"""

from __future__ import annotations

import math

import numpy as np

from .. import kernels
from .. import kinematics as kin
from ..inverse import FusedInverseDynamics

# indices of the hydraulic constants vector
# (:func:`drs_model.fidelity.hydraulic_vector.hydraulic_constants` fills it)
AREA_A, AREA_B, VOL_A0, VOL_B0, BETA = 0, 1, 2, 3, 4
K_EDGE, PORT_RATIO, P_LAMINAR, LINEAR_LAW, Q_NO_LOAD = 5, 6, 7, 8, 9
TAU_SPOOL, P_RELIEF, K_RELIEF, C_LEAK_AB, C_LEAK_EXT, P_RETURN = 10, 11, 12, 13, 14, 15
C_VISCOUS, F_COULOMB, F_BREAKAWAY, V_STRIBECK, V_SMOOTH = 16, 17, 18, 19, 20
K_STOP, C_STOP, S_MIN, S_MAX = 21, 22, 23, 24
K_POSITION, K_FEEDFORWARD, K_FORCE = 25, 26, 27
AIR_FRACTION, P_AIR_SATURATION, AIR_INDEX, P_VAPOUR = 28, 29, 30, 31
N_HYDRAULIC_CONSTANTS = 32

#: Distance from a stop [m] within which :func:`stiffest_rate` counts the stop's stiffness.
STOP_MARGIN = 5e-4

#: Servo modes (the ``mode`` argument): follow a stroke reference, or a force reference.
MODE_STROKE, MODE_FORCE = 0.0, 1.0


def effective_bulk_modulus(p, h):
    """The bulk modulus [Pa] of the oil with its entrained air at the pressure ``p`` [Pa,
    absolute, > 0] (module docstring): ``beta`` where there is no air, falling steeply below the
    air's saturation pressure, tending to ``beta`` at high pressure."""
    if h[AIR_FRACTION] == 0.0:
        return h[BETA]
    n = h[AIR_INDEX]
    phi = h[AIR_FRACTION] * (h[P_AIR_SATURATION] / p) ** (1.0 / n)
    return h[BETA] * (1.0 + phi) / (1.0 + h[BETA] * phi / (n * p))


def cavity_modulus(h):
    """The scale [Pa] of a chamber's state below the vapour pressure: the mixture's modulus at
    the vapour pressure, ``beta_e(p_v)`` (``beta`` without air), so that the state's rate is
    continuous where a cavity opens or closes (module docstring)."""
    return effective_bulk_modulus(h[P_VAPOUR], h)


def chamber_pressure(x, h):
    """The pressure [Pa] of a chamber in the state ``x`` [Pa]: ``x``, never below the vapour
    pressure."""
    return max(x, h[P_VAPOUR])


def cavity_volume(x, v, h):
    """The vapour cavity [m^3] of a chamber of volume ``v`` [m^3] in the state ``x`` [Pa]
    (0 while the chamber is full)."""
    below = h[P_VAPOUR] - x
    if below <= 0.0:
        return 0.0
    return v * below / cavity_modulus(h)


def chamber_rate(x, v, v_rate, q_in, h):
    """``dx/dt`` [Pa/s] of a chamber's state ``x`` [Pa] (module docstring): volume ``v``
    [m^3] growing at ``v_rate`` [m^3/s], net inflow ``q_in`` [m^3/s]; its continuity residual
    is ``q_in - v_rate - v / beta_e(p) dp/dt`` for a full chamber."""
    pv = h[P_VAPOUR]
    if x >= pv:
        return effective_bulk_modulus(x, h) / v * (q_in - v_rate)
    return cavity_modulus(h) / v * (q_in - v_rate) + v_rate / v * (pv - x)


def edge_flow(k, opening, dp, p_laminar, linear, q_lin):
    """Flow [m^3/s] through one metering edge of ``opening`` (0..1) under the drop ``dp`` [Pa]:
    the smoothed orifice law, or ``q_lin * opening`` for the linear (ideal) law."""
    if opening <= 0.0:
        return 0.0
    if linear > 0.5:
        return q_lin * opening
    return k * opening * dp / math.sqrt(abs(dp) + p_laminar)


def valve_flows(xv, pa, pb, ps, h):
    """``(Q_PA, Q_AT, Q_PB, Q_BT)`` [m^3/s]: the flows through the four metering edges at spool
    ``xv`` with chamber pressures ``pa``, ``pb`` and supply ``ps`` [Pa] (each positive in its
    edge's named direction; negative is backflow)."""
    k, r, plam, lin, q = h[K_EDGE], h[PORT_RATIO], h[P_LAMINAR], h[LINEAR_LAW], h[Q_NO_LOAD]
    pr = h[P_RETURN]
    pos, neg = max(xv, 0.0), max(-xv, 0.0)
    return (
        edge_flow(k, pos, ps - pa, plam, lin, q),
        edge_flow(k, neg, pa - pr, plam, lin, q),
        edge_flow(k * r, neg, ps - pb, plam, lin, q * r),
        edge_flow(k * r, pos, pb - pr, plam, lin, q * r),
    )


def edge_slope(k, opening, dp, p_laminar):
    """``dQ/d(dp)`` [m^3/(s Pa)] of :func:`edge_flow`'s orifice law at ``dp`` [Pa]."""
    a = abs(dp) + p_laminar
    return k * opening * (0.5 * abs(dp) + p_laminar) / (a * math.sqrt(a))


def relief_flow(p, h):
    """Flow [m^3/s] from a chamber at ``p`` [Pa] through its relief valve to return."""
    return h[K_RELIEF] * max(p - h[P_RELIEF], 0.0)


def friction_force(sd, h):
    """Piston friction [N] opposing the rod speed ``sd`` [m/s]: viscous plus a Coulomb term
    with a Stribeck peak, smoothed by ``tanh(sd / v_smooth)``."""
    coulomb = h[F_COULOMB]
    if coulomb == 0.0 and h[F_BREAKAWAY] == 0.0:
        return h[C_VISCOUS] * sd
    r = sd / h[V_STRIBECK]
    level = coulomb + (h[F_BREAKAWAY] - coulomb) * math.exp(-r * r)
    return h[C_VISCOUS] * sd + level * math.tanh(sd / h[V_SMOOTH])


def stop_force(s, sd, h):
    """Contact force [N] of the compliant end stops on the rod (along +s): a spring-damper while
    the rod is past ``s_min`` or ``s_max``, never pulling."""
    below = h[S_MIN] - s
    if below > 0.0:
        return max(h[K_STOP] * below - h[C_STOP] * sd, 0.0)
    above = s - h[S_MAX]
    if above > 0.0:
        return -max(h[K_STOP] * above + h[C_STOP] * sd, 0.0)
    return 0.0


def pressure_force(pa, pb, h):
    """The force [N] of the chamber pressures ``pa``, ``pb`` [Pa] on their areas (along +s)."""
    return pa * h[AREA_A] - pb * h[AREA_B]


def rod_force(pa, pb, sd, h):
    """The force [N] the cylinder gives the rod (along +s) at chamber pressures ``pa``, ``pb``
    [Pa] and rod speed ``sd`` [m/s]: the pressures on their areas less the friction (the stops'
    contact force is the mechanism's, not the cylinder's). The rung's published piston force."""
    return pressure_force(pa, pb, h) - friction_force(sd, h)


def chamber_volumes(s, h):
    """``(V_A, V_B)`` [m^3] at stroke ``s`` [m]."""
    return (h[VOL_A0] + h[AREA_A] * (s - h[S_MIN]), h[VOL_B0] + h[AREA_B] * (h[S_MAX] - s))


def servo_command(mode, s, s_ref, v_ref, f_ref, f_hyd, h):
    """Valve command ``u`` in [-1, 1] of the servo loop (module docstring)."""
    if mode > 0.5:
        u = h[K_FORCE] * (f_ref - f_hyd)
    else:
        u = h[K_FEEDFORWARD] * v_ref * h[AREA_A] / h[Q_NO_LOAD] + h[K_POSITION] * (s_ref - s)
    return min(max(u, -1.0), 1.0)


def hydraulic_derivatives(psi3, psi3d, pa, pb, xv, mode, s_ref, v_ref, f_ref, ps, spool_held, c, h):
    """``d/dt (psi3, psi3', x_A, x_B, x_v)`` (module docstring) at the chamber states ``pa``,
    ``pb`` [Pa] (the pressures while no cavity is open), with the servo references (``s_ref``
    [m], ``v_ref`` [m/s], ``f_ref`` [N]) and the supply pressure ``ps`` [Pa];
    ``spool_held > 0.5`` freezes the spool where it is (a stuck valve). NaN where the mechanism
    does not assemble."""
    s, _, us, _ = kernels.psi3_configuration(psi3, c)
    sd = us * psi3d
    xa, xb = pa, pb
    pa, pb = chamber_pressure(xa, h), chamber_pressure(xb, h)
    f_hyd = pressure_force(pa, pb, h)
    if spool_held > 0.5:
        x, dx = xv, 0.0
    else:
        u = servo_command(mode, s, s_ref, v_ref, f_ref, f_hyd, h)
        if h[TAU_SPOOL] > 0.0:
            x, dx = xv, (u - xv) / h[TAU_SPOOL]
        else:
            x, dx = u, 0.0
    q_pa, q_at, q_pb, q_bt = valve_flows(x, pa, pb, ps, h)
    q_ab = h[C_LEAK_AB] * (pa - pb)
    pr = h[P_RETURN]
    va, vb = chamber_volumes(s, h)
    q_a = q_pa - q_at - q_ab - h[C_LEAK_EXT] * (pa - pr) - relief_flow(pa, h)
    q_b = q_pb - q_bt + q_ab - h[C_LEAK_EXT] * (pb - pr) - relief_flow(pb, h)
    dpa = chamber_rate(xa, va, h[AREA_A] * sd, q_a, h)
    dpb = chamber_rate(xb, vb, -h[AREA_B] * sd, q_b, h)
    force = f_hyd - friction_force(sd, h) + stop_force(s, sd, h)
    return psi3d, kernels.psi3_acceleration(psi3, psi3d, force, c), dpa, dpb, dx


def stiffest_rate(psi3, psi3d, pa, pb, xv, ps, c, h):
    """An upper estimate of the fastest rate [1/s] of the linearised hydraulic rung at this
    state: the oil column's natural frequency with the end stop's stiffness added where the rod
    is in contact, ``sqrt((beta (A_A^2 / V_A + A_B^2 / V_B) + k_stop) / m_eff)`` with the
    mechanism's inertia reflected to the rod, ``m_eff = u.M.u / u_s^2``; the fastest decay
    (spool, friction, pressure relaxation through the valve, leaks and relief); or the rate at
    which a chamber's entrained air stiffens it (:func:`air_stiffening_rate`), whichever is
    largest."""
    sin3, cos3, s, sin1, cos1, _ = kernels.psi3_position(psi3, c)
    pa, pb = chamber_pressure(pa, h), chamber_pressure(pb, h)
    u0, u1, w0, w1 = kernels.flap_rates(sin1, cos1, sin3, cos3, c)
    umu = kernels.projected_dynamics(sin1, cos1, sin3, cos3, psi3, u0, u1, 1.0, w0, w1, 0.0, c)[0]
    m_eff = umu / (u0 * u0)
    va, vb = chamber_volumes(s, h)
    va, vb = max(va, 1e-3 * h[VOL_A0] + 1e-12), max(vb, 1e-3 * h[VOL_B0] + 1e-12)
    # beta bounds the effective modulus from above (entrained air only softens the oil)
    k_oil = h[BETA] * (h[AREA_A] ** 2 / va + h[AREA_B] ** 2 / vb)
    # the stop counts from STOP_MARGIN before contact: a step that starts there may reach it
    contact = s < h[S_MIN] + STOP_MARGIN or s > h[S_MAX] - STOP_MARGIN
    omega = math.sqrt((k_oil + (h[K_STOP] if contact else 0.0)) / m_eff)
    damping = h[C_VISCOUS] + (h[C_STOP] if contact else 0.0)
    if h[F_BREAKAWAY] > 0.0:
        damping += h[F_BREAKAWAY] / h[V_SMOOTH]
    decay = damping / m_eff
    # pressure relaxation: beta / V times the slope of the chamber's outflow in its pressure
    # (each metering edge fully open at its present drop, since the spool may open within the
    # step; the leaks, the relief)
    slope_a = h[C_LEAK_AB] + h[C_LEAK_EXT] + (h[K_RELIEF] if pa > h[P_RELIEF] else 0.0)
    slope_b = h[C_LEAK_AB] + h[C_LEAK_EXT] + (h[K_RELIEF] if pb > h[P_RELIEF] else 0.0)
    if h[LINEAR_LAW] < 0.5:
        pos, neg, plam = 1.0, 1.0, h[P_LAMINAR]
        k, kb = h[K_EDGE], h[K_EDGE] * h[PORT_RATIO]
        slope_a += edge_slope(k, pos, ps - pa, plam) + edge_slope(k, neg, pa - h[P_RETURN], plam)
        slope_b += edge_slope(kb, neg, ps - pb, plam) + edge_slope(kb, pos, pb - h[P_RETURN], plam)
    decay = max(decay, h[BETA] * max(slope_a / va, slope_b / vb))
    if h[TAU_SPOOL] > 0.0:
        decay = max(decay, 1.0 / h[TAU_SPOOL])
    sd = u0 * psi3d
    air = max(
        air_stiffening_rate(pa, va, h[AREA_A] * sd, xv, ps - pa, pa - h[P_RETURN], 1.0, h),
        air_stiffening_rate(
            pb, vb, -h[AREA_B] * sd, -xv, ps - pb, pb - h[P_RETURN], h[PORT_RATIO], h
        ),
    )
    return max(omega, decay, air)


def air_stiffening_rate(p, v, v_rate, opening, dp_in, dp_out, port, h):
    """``|d beta_e/dp| / V |Q_in - V'|`` [1/s]: how fast a chamber at ``p`` [Pa] of volume ``v``
    [m^3] growing at ``v_rate`` [m^3/s] changes its own pressure's rate through its entrained
    air's modulus, ``beta_e(p)``, steep between the vapour pressure and ~10 bar (a closed
    cavity's air compressed from ``p_v``). ``Q_in``: the metering edges' flow at ``opening``
    (its inflow edge under ``dp_in``, its outflow edge under ``dp_out`` [Pa]; with no spool lag,
    either edge fully open, whichever passes more), the edges ``port`` times the piston side's.
    0 without air."""
    if h[AIR_FRACTION] == 0.0:
        return 0.0
    n, beta = h[AIR_INDEX], h[BETA]
    phi = h[AIR_FRACTION] * (h[P_AIR_SATURATION] / p) ** (1.0 / n)
    air = beta * phi / (n * p)  # the air's share of the compliance, over the oil's
    if air < 1e-4:  # the modulus is beta's within 1e-4: it no longer changes with p
        return 0.0
    # d beta_e / dp of effective_bulk_modulus, beta (1 + phi) / (1 + air), with phi' = -phi/(n p)
    d_num = -phi / (n * p)
    d_den = -air * (1.0 + 1.0 / n) / p
    slope = beta * (d_num * (1.0 + air) - (1.0 + phi) * d_den) / ((1.0 + air) * (1.0 + air))
    k, plam, lin, q = h[K_EDGE] * port, h[P_LAMINAR], h[LINEAR_LAW], h[Q_NO_LOAD] * port
    if h[TAU_SPOOL] > 0.0:
        q_in = edge_flow(k, max(opening, 0.0), dp_in, plam, lin, q)
        q_in -= edge_flow(k, max(-opening, 0.0), dp_out, plam, lin, q)
    else:
        q_in = max(
            abs(edge_flow(k, 1.0, dp_in, plam, lin, q)),
            abs(edge_flow(k, 1.0, dp_out, plam, lin, q)),
        )
    return abs(slope) / v * abs(q_in - v_rate)


def power_balance(psi3, psi3d, pa, pb, xv, mode, s_ref, v_ref, f_ref, ps, spool_held, c, h):
    """Powers [W] at one instant: ``(supply, valve_loss, leak_loss, relief_loss, compression,
    piston, friction_loss, stop, cavitation)``, at the chamber states ``pa``, ``pb`` [Pa].

    ``supply = ps Q_P - p_r Q_T`` is the hydraulic power the supply delivers (``Q_T``: all
    that returns to the reservoir, through the valve, the outside leaks and the relief
    valves); the valve edges, the leaks and the relief valves dissipate their flow times their
    pressure drop; ``compression = p_A V_A p_A' / beta_e(p_A) + p_B V_B p_B' / beta_e(p_B)`` is
    stored in the oil and its entrained air (and given back); ``piston = (p_A A_A - p_B A_B) s'``
    reaches the rod, of which friction dissipates ``F_friction s'`` and the stops take
    ``F_stop s'`` back; ``cavitation = -p_v (V_cav,A' + V_cav,B')`` is what the vapour cavities
    give the piston as they open (negative) and take back as they close. Identity (the
    continuity equations times the pressures): ``supply = valve + leak + relief + compression +
    piston + cavitation``."""
    s, _, us, _ = kernels.psi3_configuration(psi3, c)
    sd = us * psi3d
    xa, xb = pa, pb
    pa, pb = chamber_pressure(xa, h), chamber_pressure(xb, h)
    f_hyd = pressure_force(pa, pb, h)
    if spool_held > 0.5 or h[TAU_SPOOL] > 0.0:
        x = xv
    else:
        x = servo_command(mode, s, s_ref, v_ref, f_ref, f_hyd, h)
    q_pa, q_at, q_pb, q_bt = valve_flows(x, pa, pb, ps, h)
    pr = h[P_RETURN]
    q_ext = h[C_LEAK_EXT] * ((pa - pr) + (pb - pr))
    q_relief = relief_flow(pa, h) + relief_flow(pb, h)
    supply = ps * (q_pa + q_pb) - pr * (q_at + q_bt + q_ext + q_relief)
    valve = q_pa * (ps - pa) + q_at * (pa - pr) + q_pb * (ps - pb) + q_bt * (pb - pr)
    leak = h[C_LEAK_AB] * (pa - pb) ** 2 + h[C_LEAK_EXT] * ((pa - pr) ** 2 + (pb - pr) ** 2)
    relief = relief_flow(pa, h) * (pa - pr) + relief_flow(pb, h) * (pb - pr)
    _, _, dxa, dxb, _ = hydraulic_derivatives(
        psi3, psi3d, xa, xb, xv, mode, s_ref, v_ref, f_ref, ps, spool_held, c, h
    )
    va, vb = chamber_volumes(s, h)
    compression = 0.0
    cavitation = 0.0
    # d/dt of cavity_volume(x, V) where a cavity is open (V' = A_A s', -A_B s')
    for x, dx, v, dv in ((xa, dxa, va, h[AREA_A] * sd), (xb, dxb, vb, -h[AREA_B] * sd)):
        if x >= h[P_VAPOUR]:
            compression += x * v * dx / effective_bulk_modulus(x, h)
        else:
            d_cavity = (dv * (h[P_VAPOUR] - x) - v * dx) / cavity_modulus(h)
            cavitation -= h[P_VAPOUR] * d_cavity
    return (
        supply,
        valve,
        leak,
        relief,
        compression,
        f_hyd * sd,
        friction_force(sd, h) * sd,
        stop_force(s, sd, h) * sd,
        cavitation,
    )


def switching_functions(psi3, psi3d, pa, pb, xv, mode, s_ref, v_ref, f_ref, ps, spool_held, c, h):
    """Where :func:`hydraulic_derivatives` is not smooth, as 15 functions of the state that
    change sign there (a reference that locates them integrates only smooth pieces): the spool
    through the null (where the metering edges open), the servo command at its clips, the four
    edges' pressure drops through zero (the laminar law is once differentiable there), each
    chamber at its relief pressure and at the vapour pressure, the rod at each stop, and the
    stop's damping reaching zero (a stop never pulls). A function that cannot change sign at
    this state (the damping away from the stop) is 1."""
    s, _, _, _ = kernels.psi3_configuration(psi3, c)
    p_a, p_b = chamber_pressure(pa, h), chamber_pressure(pb, h)
    f_hyd = pressure_force(p_a, p_b, h)
    if mode > 0.5:
        u = h[K_FORCE] * (f_ref - f_hyd)
    else:
        u = h[K_FEEDFORWARD] * v_ref * h[AREA_A] / h[Q_NO_LOAD] + h[K_POSITION] * (s_ref - s)
    if spool_held > 0.5 or h[TAU_SPOOL] > 0.0:
        x = xv
    else:
        x = min(max(u, -1.0), 1.0)
    if spool_held > 0.5:
        u = 0.0  # the command does not act on a stuck spool
    pr = h[P_RETURN]
    below, above, damp_closed, damp_open = stop_switches(psi3, psi3d, c, h)
    return (
        x,
        u - 1.0,
        u + 1.0,
        ps - p_a,
        p_a - pr,
        ps - p_b,
        p_b - pr,
        p_a - h[P_RELIEF],
        p_b - h[P_RELIEF],
        pa - h[P_VAPOUR],
        pb - h[P_VAPOUR],
        below,
        above,
        damp_closed,
        damp_open,
    )


def stop_switches(psi3, psi3d, c, h):
    """Where a stop's contact begins (its damping force jumps) or ends, as the last four of
    :func:`switching_functions`: the rod past the closed and the open stop [m] (positive past
    it), and each stop's spring-damper force before its clip at zero [N] (a stop never pulls;
    1 away from the stop)."""
    s, _, us, _ = kernels.psi3_configuration(psi3, c)
    sd = us * psi3d
    below, above = h[S_MIN] - s, s - h[S_MAX]
    damp_closed = h[K_STOP] * below - h[C_STOP] * sd if below > 0.0 else 1.0
    damp_open = h[K_STOP] * above + h[C_STOP] * sd if above > 0.0 else 1.0
    return below, above, damp_closed, damp_open


def equilibrium_state(s: float, p, hp, ps: float | None = None):
    """``y = (psi3, 0, p_A, p_B, 0)`` at rest at stroke ``s`` [m] for the parameters ``p``
    (:class:`~drs_model.params.DRSParams`) and ``hp`` (``HydraulicParams``), supply ``ps`` [Pa]
    (default ``hp``'s): the chamber pressures give the static piston force
    (:class:`~drs_model.inverse.FusedInverseDynamics` at rest) and sit symmetrically about the
    valve's null, ``p_A + p_B = p_s + p_r``. Not a kernel: the rung's start and probes."""
    ps = hp.supply_pressure if ps is None else ps
    force = FusedInverseDynamics.from_params(p).force(s, 0.0, 0.0)
    area_a, area_b = hp.piston_area, hp.rod_side_area
    pa = (force + (ps + hp.return_pressure) * area_b) / (area_a + area_b)
    pb = ps + hp.return_pressure - pa
    psi3 = float(kin.solve_position(s, p)[..., 2])
    return np.array([psi3, 0.0, pa, pb, 0.0])


#: Every kernel of this module (registered with numba where a compiled kernel calls it).
KERNELS = (
    effective_bulk_modulus,
    cavity_modulus,
    chamber_pressure,
    cavity_volume,
    chamber_rate,
    edge_flow,
    edge_slope,
    valve_flows,
    relief_flow,
    friction_force,
    stop_force,
    pressure_force,
    rod_force,
    chamber_volumes,
    servo_command,
    hydraulic_derivatives,
    stiffest_rate,
    air_stiffening_rate,
    power_balance,
    switching_functions,
    stop_switches,
)
