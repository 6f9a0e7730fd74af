"""Position, velocity and acceleration analysis; seed numbers and finite differences."""

from __future__ import annotations

import math

import kinematics_support
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from drs_model import kinematics as kin
from drs_model.constraints import constraint, singularity_measure
from drs_model.errors import (
    AssemblyError,
    InputError,
    SingularConfigurationError,
    StrokeRangeError,
)
from drs_model.profile import drs_manoeuvre

# seed 003 printed values
SEED_S0_BRANCHES = {1: (-0.1824644031, 1.093620968), 2: (-0.5760483505, 1.289458931)}
SEED_SINGULAR = [
    (0.2775528574, -2.766169046, -1.195372719),
    (-0.001552857370, -0.3754236080, 1.195372719),
]
SEED_S_MIN, SEED_S_MAX = 0.000198939129915359, 0.0460748980054946
SEED_PSI3_CLOSED, SEED_PSI3_OPEN = 1.087075800, 0.5487704485


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def test_closed_form_at_s0_matches_seed_within_its_precision(params):
    """The seed's values violate Phi by ~5e-7 m; with dpsi/ds ~ 60 rad/m that is ~3e-5 rad."""
    for branch, (psi1, psi3) in SEED_S0_BRANCHES.items():
        q = kin.solve_position(0.0, params, branch)
        assert np.abs(constraint(q, params)).max() < 1e-15
        assert q[1] == pytest.approx(psi1, abs=5e-5)
        assert q[2] == pytest.approx(psi3, abs=5e-5)


def test_singular_strokes_match_seed(params):
    sing = kin.singular_strokes(params)
    # 10 significant digits printed: half a unit of the last digit
    assert sing == pytest.approx(sorted(s for s, _, _ in SEED_SINGULAR), rel=5e-10)
    q = kinematics_support.singular_configurations(params)
    for s, psi1, psi3 in SEED_SINGULAR:
        row = q[np.argmin(np.abs(q[:, 0] - s))]
        assert wrap(row[1] - psi1) == pytest.approx(0.0, abs=1e-9)
        assert wrap(row[2] - psi3) == pytest.approx(0.0, abs=1e-9)
        assert singularity_measure(row, params) < 1e-7
        # both branches meet there
        np.testing.assert_allclose(
            kin.solve_position(row[0], params, 2), kin.solve_position(row[0], params, 1), atol=2e-6
        )
    assert kin.dead_centre(params) == pytest.approx(-0.001552857370, abs=1e-12)


def test_psi3_parametrisation_matches_seed_check_values(params):
    """seed (2.3.7.3): psi3_kin_sol at its printed closed and open angles."""
    q = kin.solve_position_from_flap_angle(np.array([SEED_PSI3_CLOSED, SEED_PSI3_OPEN]), params)
    assert q[0, 1] == pytest.approx(-0.1706753036, abs=1e-10)
    assert q[0, 0] == pytest.approx(0.0001994128, abs=1e-10)
    # Maple ran at Digits = 10: arcsin(2 cos(psi3) - 1.1) loses ~1e-10 to cancellation there
    assert q[1, 1] == pytest.approx(0.6514412053, abs=1e-9)
    # s = 0.138 - ...: ten digits of terms of size 0.1 carry ~1e-11 of rounding each
    assert q[1, 0] == pytest.approx(0.04607560011, abs=1e-10)
    assert np.abs(constraint(q, params)).max() < 1e-15


def test_stroke_limits_solve_the_gap_rule_exactly(params):
    s_min, s_max = kin.stroke_limits(params)
    q = kin.solve_position(np.array([s_min, s_max]), params)
    assert np.abs(constraint(q, params)).max() < 1e-12
    np.testing.assert_allclose(kin.gap(q, params), [0.01, 0.05], atol=1e-12)
    # independent cross-check: a root finder on gap(solve_position(s)) in s
    for target, ours in ((0.01, s_min), (0.05, s_max)):
        root = brentq(
            lambda s, g=target: kin.gap(kin.solve_position(s, params), params) - g,
            0.0,
            0.27,
            xtol=1e-16,
            rtol=1e-15,
        )
        assert root == pytest.approx(ours, abs=1e-14)
    # the seed's NLPSolve limits miss the rule (README: 10.0007 mm and 50.0005 mm). First order
    # from the exact limits: dgap/ds = -(L_wing - d_tip) cos(psi3) dpsi3/ds, with the seed's
    # printed velocity ratio tau3 = -cos(psi1) / (L3 cos(psi1 - psi3)) (2.4.1.1)
    seed_gaps = kin.gap(kin.solve_position(np.array([SEED_S_MIN, SEED_S_MAX]), params), params)
    for k, (exact_s, seed_s, target) in enumerate(
        ((s_min, SEED_S_MIN, 0.01), (s_max, SEED_S_MAX, 0.05))
    ):
        _, psi1, psi3 = kin.solve_position(exact_s, params)
        tau3 = -math.cos(psi1) / (params.L3 * math.cos(psi1 - psi3))
        predicted = target - params.tip_arm * math.cos(psi3) * tau3 * (seed_s - exact_s)
        assert seed_gaps[k] == pytest.approx(predicted, abs=2e-9)
        assert abs(seed_gaps[k] - target) > 4e-7  # the seed's limits are off by > 0.4 um
    assert s_min == pytest.approx(SEED_S_MIN, abs=1e-6)
    assert s_max == pytest.approx(SEED_S_MAX, abs=1e-6)


def test_flap_angle_range(params):
    closed, opened = kin.flap_angle_limits(params)
    assert closed > opened  # the flap closes at the larger angle (the seed swaps the labels)
    assert closed == pytest.approx(SEED_PSI3_CLOSED, abs=5e-5)
    assert opened == pytest.approx(SEED_PSI3_OPEN, abs=5e-5)
    # gap from the point positions of T and R
    q = kin.solve_position_from_flap_angle(np.array([closed, opened]), params)
    pts = kin.point_positions(q, params, ("T", "R"))
    np.testing.assert_allclose(pts["T"][:, 1] - pts["R"][:, 1], [0.01, 0.05], atol=1e-15)


def test_velocity_ratio_near_the_dead_centre(params):
    """dpsi3/ds ~ -32 rad/m closed and ~ -8 rad/m open (the closed position is 1.75 mm from
    the dead centre)."""
    s_min, s_max = kin.stroke_limits(params)
    q = kin.solve_position(np.array([s_min, s_max]), params)
    tau = kin.velocity_ratio(q, params)
    # the seed's printed velocity ratio (2.4.1.1), evaluated independently
    psi1, psi3 = q[:, 1], q[:, 2]
    seed_tau1 = np.sin(psi3) / (params.L2 * np.cos(psi1 - psi3))
    seed_tau3 = -np.cos(psi1) / (params.L3 * np.cos(psi1 - psi3))
    np.testing.assert_allclose(tau[:, 1], seed_tau1, rtol=1e-12)
    np.testing.assert_allclose(tau[:, 2], seed_tau3, rtol=1e-12)
    assert round(tau[0, 2]) == -32 and round(tau[1, 2]) == -8  # the design note's figures
    assert s_min - kin.dead_centre(params) == pytest.approx(0.00175, abs=1e-5)


@given(st.floats(-0.0015, 0.2775), st.sampled_from([1, 2]))
@settings(max_examples=80, deadline=None)
def test_both_branches_satisfy_phi(params, s, branch):
    q = kin.solve_position(s, params, branch)
    assert np.abs(constraint(q, params)).max() < 1e-14


@given(st.floats(0.0, 0.05))
@settings(max_examples=60, deadline=None)
def test_velocity_ratio_against_finite_differences(params, s):
    h = 1e-7
    fd = (kin.solve_position(s + h, params) - kin.solve_position(s - h, params)) / (2 * h)
    np.testing.assert_allclose(
        kin.velocity_ratio(kin.solve_position(s, params), params), fd, rtol=1e-6, atol=1e-6
    )


@given(st.floats(0.5, 1.1))
@settings(max_examples=60, deadline=None)
def test_psi3_parametrisation_against_finite_differences(params, psi3):
    h = 1e-7
    f = kin.solve_position_from_flap_angle
    fd = (f(psi3 + h, params) - f(psi3 - h, params)) / (2 * h)
    q = f(psi3, params)
    np.testing.assert_allclose(kin.velocity_ratio(q, params, "psi3"), fd, rtol=1e-6, atol=1e-8)
    # and it agrees with the s-parametrisation (same branch)
    np.testing.assert_allclose(kin.solve_position(q[0], params), q, atol=1e-12)


def _trajectory(params, t):
    s, v, a = drs_manoeuvre(params).evaluate(t)
    return kin.kinematic_state(s, v, a, params)


def test_velocities_and_accelerations_against_time_differences(params):
    t = np.linspace(0.0005, 0.0095, 19)
    h = 1e-7
    st_ = _trajectory(params, t)
    qp, qm = _trajectory(params, t + h).q, _trajectory(params, t - h).q
    np.testing.assert_allclose(st_.qd, (qp - qm) / (2 * h), rtol=1e-6, atol=1e-5)
    h2 = 1e-5
    qp, qm = _trajectory(params, t + h2).q, _trajectory(params, t - h2).q
    np.testing.assert_allclose(st_.qdd, (qp - 2 * st_.q + qm) / h2**2, rtol=1e-4, atol=1.0)
    # the psi3-parametrised route gives the same state
    alt = kinematics_support.kinematic_state_from_flap(
        st_.q[:, 2], st_.qd[:, 2], st_.qdd[:, 2], params
    )
    np.testing.assert_allclose(alt.q, st_.q, atol=1e-12)
    np.testing.assert_allclose(alt.qd, st_.qd, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(alt.qdd, st_.qdd, rtol=1e-9, atol=1e-6)


def test_point_kinematics_against_time_differences(params):
    t = np.linspace(0.001, 0.009, 9)
    h = 1e-6
    st_ = _trajectory(params, t)
    vel = kinematics_support.point_velocities(st_.q, st_.qd, params)
    acc = kin.point_accelerations(st_.q, st_.qd, st_.qdd, params)
    pos_p = kin.point_positions(_trajectory(params, t + h).q, params)
    pos_0 = kin.point_positions(st_.q, params)
    pos_m = kin.point_positions(_trajectory(params, t - h).q, params)
    for name in kin.POINT_NAMES:
        fd_v = (pos_p[name] - pos_m[name]) / (2 * h)
        fd_a = (pos_p[name] - 2 * pos_0[name] + pos_m[name]) / h**2
        scale_v = 1 + np.abs(fd_v).max()
        scale_a = 1 + np.abs(fd_a).max()
        np.testing.assert_allclose(vel[name], fd_v, atol=1e-6 * scale_v, err_msg=name)
        np.testing.assert_allclose(acc[name], fd_a, atol=2e-3 * scale_a, err_msg=name)
    # C (link) and C3 (flap) are the same point of the closed loop
    np.testing.assert_allclose(vel["C"], vel["C3"], atol=1e-12)
    np.testing.assert_allclose(acc["C"], acc["C3"], atol=1e-8)


@given(st.tuples(st.floats(0.0, 0.05), st.floats(-1, 1), st.floats(-1, 1)).map(np.array))
@settings(max_examples=40, deadline=None)
def test_point_jacobians_against_central_differences(params, q):
    h = 1e-7
    for name in ("P", "G1", "B", "G2", "C", "T", "G3"):
        fd = np.stack(
            [
                (
                    kin.point_positions(q + h * e, params, (name,))[name]
                    - kin.point_positions(q - h * e, params, (name,))[name]
                )
                / (2 * h)
                for e in np.eye(3)
            ],
            axis=-1,
        )
        np.testing.assert_allclose(kin.point_jacobian(name, q, params), fd, atol=1e-8)


def test_newton_solver_converges_to_the_nearest_branch(params):
    for branch in (1, 2):
        exact = kin.solve_position(0.02, params, branch)
        out = kin.newton_position(exact + np.array([0.0, 0.05, -0.05]), params)
        assert out.converged and out.residual < 1e-13 and out.iterations <= 8
        np.testing.assert_allclose(out.q, exact, atol=1e-12)
    # psi3 independent
    exact = kin.solve_position_from_flap_angle(0.8, params)
    out = kin.newton_position(exact + np.array([0.002, 0.05, 0.0]), params, "psi3")
    assert out.converged
    np.testing.assert_allclose(out.q, exact, atol=1e-12)


def test_newton_reports_failure_instead_of_raising(params):
    out = kin.newton_position(np.array([0.5, 0.0, 0.0]), params, maxiter=30)  # beyond assembly
    assert not out.converged
    assert out.message in (
        "maximum iterations reached",
        "singular dependent Jacobian",
        "diverged (non-finite iterate)",
    )
    from drs_model.errors import ConvergenceError

    with pytest.raises(ConvergenceError, match=r"Newton position solve failed at s=0\.5 m"):
        kinematics_support.solve_position_newton(0.5, np.array([0.5, 0.0, 0.0]), params)


def test_workspace_traces(params):
    tr = kin.workspace_traces(params, 20)
    assert np.allclose(tr["B"][:, 0], params.x_A)
    np.testing.assert_allclose(np.linalg.norm(tr["C"] - tr["B"], axis=1), params.L2, atol=1e-14)
    d = np.array([params.x_D, params.y_D])
    np.testing.assert_allclose(np.linalg.norm(tr["C"] - d, axis=1), params.L3, atol=1e-14)


def test_outlines(params):
    q = kin.solve_position(0.01, params)
    fl = kin.flap_outline(q, params)
    # the outline's mean is G3 (seed's getCoM), its first local point (0, 0) is T
    np.testing.assert_allclose(fl.mean(axis=0), kin.point_positions(q, params)["G3"], atol=1e-15)
    assert kin.main_wing_outline(params).shape == (43, 2)


def test_errors(params):
    with pytest.raises(AssemblyError, match=r"cannot close at stroke 0\.5 m: assembly needs"):
        kin.solve_position(0.5, params)
    with pytest.raises(InputError, match=r"stroke must be finite, got nan"):
        kin.solve_position(math.nan, params)
    with pytest.raises(InputError, match=r"branch must be 1 or 2, got 3"):
        kin.solve_position(0.0, params, 3)
    with pytest.raises(AssemblyError, match=r"cannot close at flap angle 3\.0 rad"):
        kin.solve_position_from_flap_angle(3.0, params)
    with pytest.raises(StrokeRangeError, match=r"gap 0\.5 m is unreachable"):
        kin.flap_angle_for_gap(0.5, params)
    with pytest.raises(StrokeRangeError, match=r"stroke 0\.06 m is outside \[s_min, s_max\]"):
        kin.check_stroke(0.06, params)
    sing = kinematics_support.singular_configurations(params)[0]
    with pytest.raises(SingularConfigurationError, match=r"'s' cannot be the independent"):
        kin.velocity_ratio(sing, params)
    # the psi3 parametrisation is regular at the same configuration
    assert np.all(np.isfinite(kin.velocity_ratio(sing, params, "psi3")))
