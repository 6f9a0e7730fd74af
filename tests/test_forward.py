"""Forward dynamics: formulations against the library, the manoeuvre round trip, energy, drift,
the open-loop growth rate, and the typed failures."""

from __future__ import annotations

import math
import re

import forward_support
import kinematics_support
import numpy as np
import pytest

from drs_model import bodies as bo
from drs_model import forward as fw
from drs_model import kinematics as kin
from drs_model.constraints import constraint, constraint_jacobian
from drs_model.errors import (
    ConstraintDriftError,
    DRSError,
    InputError,
    IntegrationError,
    SingularConfigurationError,
)
from drs_model.forward import simulate

ALL = ("psi3", "s", "index1", "baumgarte", "projection")
FULL = ("index1", "baumgarte", "projection")


@pytest.fixture(scope="module")
def mforce(params):
    return fw.ManoeuvreForce(params)


def _opts(form):
    return {"drift_bound": 1e-3} if form in FULL else {}


def _closed_rate(params, mforce) -> float:
    """Growth rate sqrt(d psi3''/d psi3) [1/s] at rest closed under the holding force, from the
    numpy library right-hand side (not the scalar kernel)."""
    f = fw.Psi3Minimal(params)
    b = float(kin.solve_position(kin.stroke_limits(params)[0], params)[2])
    F, h = mforce(0.0), 1e-6
    ap = forward_support.reference_rhs(f, 0.0, np.array([b + h, 0.0]), F)[1]
    am = forward_support.reference_rhs(f, 0.0, np.array([b - h, 0.0]), F)[1]
    return math.sqrt((ap - am) / (2 * h))


# ---- right-hand sides -----------------------------------------------------------------------
@pytest.mark.parametrize("name", ALL)
def test_scalar_kernels_match_numpy_library(params, name):
    """The math kernels equal the KKT / virtual-work right-hand sides built from bodies.py,
    constraints.py and kinematics.py, also off the constraint manifold for full coordinates."""
    form = fw.get_formulation(name, params)
    rng = np.random.default_rng(3)
    for _ in range(5):
        s = rng.uniform(0.0005, 0.045)
        q = kin.solve_position(s, params)
        qd = kin.velocity_ratio(q, params) * rng.normal(0.0, 3.0)
        if form.full:
            y = np.concatenate([q + rng.normal(0, 1e-4, 3), qd + rng.normal(0, 1e-2, 3)])
        else:
            y = form.initial_state(q, qd)
        force = rng.normal(0.0, 1000.0)
        got = form.fun(lambda t, f=force: f)(0.0, y)
        ref = forward_support.reference_rhs(form, 0.0, y, force)
        np.testing.assert_allclose(got, ref, rtol=1e-11, atol=1e-9)


def test_minimal_accelerations_satisfy_the_full_equations(params):
    """psi3'' of (a), mapped to qdd = u psi3'' + w psi3'^2, satisfies M qdd + h = Q + Phi_q^T lam
    for some lam (the residual lies in the range of Phi_q^T)."""
    form = fw.Psi3Minimal(params)
    b, bd, force = 0.8, 25.0, 400.0
    acc = form.accel(b, bd, force)
    st = kinematics_support.kinematic_state_from_flap(b, bd, acc, params)
    res = (
        bo.mass_matrix(st.q, params) @ st.qdd
        + bo.velocity_forces(st.q, st.qd, params)
        - bo.applied_forces(st.q, force, params)
    )
    jac = constraint_jacobian(st.q, params)
    lam, *_ = np.linalg.lstsq(jac.T, res, rcond=None)
    np.testing.assert_allclose(jac.T @ lam, res, atol=1e-9 * np.max(np.abs(res)))


def test_manoeuvre_force_equals_virtual_work_projection(params, mforce):
    """F = u.(M qdd + h - Q(q, 0)) / u_s with u = velocity_ratio (the library's numpy path)."""
    t = np.linspace(-0.005, 0.055, 61)
    s, sd, sdd = mforce.profile(t)
    st = kin.kinematic_state(s, sd, sdd, params)
    u = kin.velocity_ratio(st.q, params)
    lhs = (
        np.einsum("nij,nj->ni", bo.mass_matrix(st.q, params), st.qdd)
        + bo.velocity_forces(st.q, st.qd, params)
        - bo.applied_forces(st.q, 0.0, params)
    )
    ref = np.einsum("ni,ni->n", u, lhs) / u[:, 0]
    got = np.array([mforce(x) for x in t])
    np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-8)
    # each piece, used on its own segment, matches at and around the joints (C0 force)
    for a, b in zip(mforce.breakpoints[:-1], mforce.breakpoints[1:], strict=True):
        piece = mforce.segment(a, b)
        assert piece(a) == pytest.approx(mforce(a), rel=1e-9, abs=1e-6)
        assert piece(b) == pytest.approx(mforce(b - 1e-15), rel=1e-9, abs=1e-6)


def test_manoeuvre_force_agrees_with_dynamics_module(params, mforce):
    from drs_model import inverse as dyn

    t = np.linspace(0.0, params.T_total, 41)
    np.testing.assert_allclose(
        [mforce(x) for x in t], dyn.manoeuvre_force(t, params), rtol=1e-9, atol=1e-7
    )


# ---- round trip -------------------------------------------------------------------------------
def _round_trip_bound(params, mforce, rtol: float) -> float:
    """Error budget [m]: a local error ~ rtol * 0.05 m (the stroke scale of atol) per step, grown at
    most by exp(lambda_closed * T_total) (the open-loop instability; lambda ~ 120/s closed, ~36/s
    open), times 10 for the number of error-carrying steps."""
    lam = _closed_rate(params, mforce)
    return 10.0 * rtol * 0.05 * math.exp(lam * params.T_total)


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize("rtol", [1e-6, 1e-10])
def test_round_trip_reproduces_profile(params, mforce, name, rtol):
    """Forward dynamics under the inverse-dynamics force of the manoeuvre gives back s(t).

    The force is exact, so the profile is the exact solution; the error is the integrator's,
    amplified by the unstable open loop (a state error grows ~e^(120 t) while closed)."""
    t = np.linspace(0.0, params.T_total, 201)
    sol = simulate(
        name,
        mforce,
        (0.0, params.T_total),
        params=params,
        method="DOP853",
        rtol=rtol,
        t_eval=t,
        **_opts(name),
    )
    s_ref = mforce.profile(t)[0]
    psi_ref = kin.solve_position(s_ref, params)[:, 2]
    bound = _round_trip_bound(params, mforce, rtol)
    assert np.max(np.abs(sol.s - s_ref)) < bound
    # dpsi3/ds is at most ~32 rad/m over the stroke
    assert np.max(np.abs(sol.psi3 - psi_ref)) < 40.0 * bound
    np.testing.assert_array_equal(sol.t, t)


def test_formulations_agree_with_each_other(params, mforce):
    t = np.linspace(0.0, params.T_total, 101)
    runs = {
        name: simulate(
            name,
            mforce,
            (0.0, params.T_total),
            params=params,
            method="DOP853",
            rtol=1e-11,
            t_eval=t,
            **_opts(name),
        )
        for name in ALL
    }
    ref = runs["psi3"]
    for name, sol in runs.items():
        np.testing.assert_allclose(sol.q, ref.q, atol=2e-9, err_msg=name)
        np.testing.assert_allclose(sol.qd, ref.qd, rtol=1e-6, atol=2e-6, err_msg=name)


# ---- the open-loop instability -------------------------------------------------------------------
def test_open_loop_growth_rate_closed_is_about_120_per_second(params, mforce):
    lam = _closed_rate(params, mforce)
    assert 110.0 < lam < 130.0
    # and the scalar kernel linearises the same
    f = fw.Psi3Minimal(params)
    b = float(kin.solve_position(kin.stroke_limits(params)[0], params)[2])
    k = (f.accel(b + 1e-6, 0.0, mforce(0.0)) - f.accel(b - 1e-6, 0.0, mforce(0.0))) / 2e-6
    assert math.sqrt(k) == pytest.approx(lam, rel=1e-6)


def test_perturbation_grows_like_cosh_lambda_t(params, mforce):
    """A 1e-9 rad offset of psi3 at rest, closed, under the holding force: the deviation follows
    delta cosh(lambda t) of the linearisation (10 ms: growth ~ 1.8)."""
    lam = _closed_rate(params, mforce)
    q0 = kin.solve_position(kin.stroke_limits(params)[0], params)
    delta, t_end = 1e-9, 0.02
    f_hold = mforce(0.0)
    base = simulate(
        "psi3", f_hold, (0.0, t_end), params=params, rtol=1e-13, y0=[q0[2], 0.0], t_eval=[t_end]
    )
    pert = simulate(
        "psi3",
        f_hold,
        (0.0, t_end),
        params=params,
        rtol=1e-13,
        y0=[q0[2] + delta, 0.0],
        t_eval=[t_end],
    )
    growth = (pert.psi3[-1] - base.psi3[-1]) / delta
    assert growth == pytest.approx(math.cosh(lam * t_end), rel=0.02)
    assert growth > 5.0  # unstable indeed


def test_open_end_is_unstable_too_but_slower(params, mforce):
    f = fw.Psi3Minimal(params)
    b = float(kin.solve_position(kin.stroke_limits(params)[1], params)[2])
    f_hold = mforce(0.5 * params.T_total)
    assert abs(f.accel(b, 0.0, f_hold)) < 1e-6  # the hold force is an equilibrium
    k = (f.accel(b + 1e-6, 0.0, f_hold) - f.accel(b - 1e-6, 0.0, f_hold)) / 2e-6
    assert 0.0 < math.sqrt(k) < _closed_rate(params, mforce)


# ---- energy -------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["psi3", "s", "projection", "index1"])
@pytest.mark.parametrize("force", [0.0, 40.0])
def test_energy_balance_without_air(params, name, force):
    """No air: T + V - F s is conserved under gravity and a constant piston force."""
    p = params.replace(F_drag_closed=0.0, F_drag_open=0.0, F_down_closed=0.0, F_down_open=0.0)
    q0 = kin.solve_position(0.02, p)
    qd0 = kin.velocity_ratio(q0, p) * 0.5

    def energy(q, qd):
        return bo.kinetic_energy(q, qd, p) + bo.potential_energy(q, p) - force * q[..., 0]

    sol = simulate(
        name,
        force,
        (0.0, 0.01),
        params=p,
        rtol=1e-12,
        initial=(q0, qd0),
        t_eval=np.linspace(0, 0.01, 21),
        **_opts(name),
    )
    e = energy(sol.q, sol.qd)
    scale = bo.kinetic_energy(sol.q, sol.qd, p).max()
    assert np.max(np.abs(e - e[0])) < 1e-8 * scale
    assert np.ptp(sol.s) > 1e-3  # it moved


# ---- constraint drift ---------------------------------------------------------------------------
def test_index1_drifts_baumgarte_bounded_projection_exact(params, mforce):
    kw = dict(params=params, method="RK45", rtol=1e-5, drift_bound=1.0)
    span = (0.0, params.T_total)
    plain = simulate("index1", mforce, span, **kw)
    stab = simulate("baumgarte", mforce, span, alpha=200.0, beta=200.0, **kw)
    proj = simulate("projection", mforce, span, **kw)
    r = plain.residual
    assert r[-1] > 10.0 * r[len(r) // 4] and r[-1] > 1e-7  # grows with time
    assert stab.residual.max() < 0.5 * r[-1]
    assert proj.residual.max() < 1e-15  # at every accepted step
    assert proj.velocity_residual.max() < 1e-13
    # the accepted states themselves (no projection of the output in between)
    q, qd = proj.y[:3].T, proj.y[3:].T
    assert np.max(np.abs(constraint(q, params))) < 1e-15
    assert np.max(np.abs(np.einsum("nij,nj->ni", constraint_jacobian(q, params), qd))) < 1e-13


def test_baumgarte_removes_an_initial_violation(params, mforce):
    """A 1e-6 rad error in psi1 (|Phi| ~ 4e-8 m): index 1 keeps it (Phi'' = 0 from rest),
    Baumgarte damps it as its gains prescribe."""
    q = kin.solve_position(kin.stroke_limits(params)[1], params)
    y0 = np.concatenate([q + [0.0, 1e-6, 0.0], np.zeros(3)])
    f_hold = mforce(0.5 * params.T_total)
    kw = dict(params=params, method="DOP853", rtol=1e-10, t_eval=[0.03], y0=y0)
    plain = simulate("index1", f_hold, (0.0, 0.03), **kw)
    stab = simulate("baumgarte", f_hold, (0.0, 0.03), alpha=300.0, beta=300.0, **kw)
    phi0 = float(np.max(np.abs(constraint(q + [0.0, 1e-6, 0.0], params))))
    assert plain.residual[-1] == pytest.approx(phi0, rel=0.05)
    # alpha = beta: Phi'' + 2 a Phi' + a^2 Phi = 0, critically damped from rest
    a, t = 300.0, 0.03
    assert stab.residual[-1] == pytest.approx(phi0 * (1 + a * t) * math.exp(-a * t), rel=0.05)


def test_drift_past_bound_raises(params, mforce):
    with pytest.raises(ConstraintDriftError, match=r"exceeds drift_bound = 1e-07 m"):
        simulate(
            "index1",
            mforce,
            (0.0, params.T_total),
            params=params,
            method="RK45",
            rtol=1e-3,
            drift_bound=1e-7,
        )


# ---- failure modes ----------------------------------------------------------------------------
def test_s_formulation_refuses_the_dead_centre(params, mforce):
    """80 % of the closed holding force lets the flap close past s_min towards the dead centre."""
    s_dead = kin.dead_centre(params)
    with pytest.raises(SingularConfigurationError, match=re.escape(f"s_dead = {s_dead:.9g} m")):
        simulate("s", 0.8 * mforce(0.0), (0.0, 0.03), params=params, rtol=1e-9)
    # the psi3 formulation goes through: s has a minimum at the dead centre, then rises
    t = np.linspace(0.0, 0.03, 3001)
    sol = simulate("psi3", 0.8 * mforce(0.0), (0.0, 0.03), params=params, rtol=1e-9, t_eval=t)
    i = int(np.argmin(sol.s))
    psi3_dead = float(kin.solve_position(s_dead, params)[2])
    assert sol.psi3[-1] > psi3_dead > sol.psi3[0]
    assert s_dead - 1e-12 <= sol.s[i] < s_dead + 1e-5
    assert 0 < i < sol.s.size - 1


def test_s_formulation_message_names_the_stroke(params):
    form = fw.StrokeMinimal(params, dead_centre_margin=1e-3)
    q = kin.solve_position(kin.dead_centre(params) + 5e-4, params)
    with pytest.raises(SingularConfigurationError, match=r"stroke s = -0\.00105\d* m"):
        form.initial_state(q, np.zeros(3))


def test_psi3_formulation_refuses_a_horizontal_link(params):
    with pytest.raises(SingularConfigurationError, match=r"cos psi1 = .* < min_cos_psi1"):
        simulate("psi3", 0.0, (0.0, 0.01), params=params, y0=[1.55, 0.0])


def test_nan_force_is_typed(params):
    with pytest.raises(IntegrationError, match=r"piston force is not finite at t = "):
        simulate("psi3", lambda t: math.nan if t > 0.002 else 1000.0, (0.0, 0.01), params=params)
    with pytest.raises(InputError, match=r"constant piston force must be finite"):
        simulate("psi3", math.nan, (0.0, 0.01), params=params)


def test_step_size_collapse_is_typed(params, mforce):
    with pytest.raises(IntegrationError, match=r"step size collapsed to .* < min_step"):
        simulate("psi3", mforce, (0.0, 0.01), params=params, rtol=1e-12, min_step=5e-3)


def test_lsoda_cannot_project(params):
    with pytest.raises(InputError, match="LSODA keeps its state inside Fortran"):
        simulate("projection", 300.0, (0.0, 0.001), params=params, method="LSODA")


def test_bad_arguments(params):
    with pytest.raises(InputError, match="formulation must be one of"):
        simulate("lagrange", 0.0, (0, 1), params=params)
    with pytest.raises(InputError, match="method must be one of"):
        simulate("psi3", 0.0, (0, 1), params=params, method="Euler")
    with pytest.raises(InputError, match="t_span"):
        simulate("psi3", 0.0, (1.0, 0.0), params=params)
    with pytest.raises(InputError, match="violates the constraints"):
        simulate("index1", 0.0, (0, 1), params=params, initial=([0.01, 0.0, 0.0], np.zeros(3)))
    with pytest.raises(InputError, match="Baumgarte gain alpha"):
        fw.FullCoordinates(params, alpha=-1.0)
    assert issubclass(ConstraintDriftError, DRSError)
