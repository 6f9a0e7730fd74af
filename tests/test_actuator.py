"""The actuator simulation (model only): modes, commands, end stops, scalar kinematics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model import kinematics as kin
from drs_model.actuator import ActuatorSim
from drs_model.constraints import constraint
from drs_model.errors import InputError, StrokeRangeError
from drs_model.inverse import inverse_dynamics
from drs_model.profile import drs_manoeuvre


def lagrange_force(params, s, sd=0.0, sdd=0.0):
    st_ = kin.kinematic_state(np.atleast_1d(s), np.atleast_1d(sd), np.atleast_1d(sdd), params)
    return float(inverse_dynamics(st_, params, method="lagrange").piston_force[0])


def test_starts_closed_at_rest_holding_the_static_force(params):
    a = ActuatorSim(params)
    s_min, _ = kin.stroke_limits(params)
    st_ = a.state
    assert st_.mode == "hold" and st_.q[0] == s_min and st_.gap == pytest.approx(0.01, abs=1e-15)
    assert st_.piston_force == pytest.approx(lagrange_force(params, s_min), rel=1e-10)
    assert st_.dead_centre_distance == pytest.approx(s_min - kin.dead_centre(params), abs=1e-15)


def test_open_follows_the_seed_opening_and_its_force(params):
    a = ActuatorSim(params, dt=1e-3)
    a.command_drs(True)
    m = drs_manoeuvre(params)
    for k in range(1, 11):
        st_ = a.step()
        s, v, acc = m.evaluate(k * 1e-3)
        assert st_.q[0] == pytest.approx(float(s), abs=1e-15)
        assert st_.piston_force == pytest.approx(lagrange_force(params, s, v, acc), rel=1e-9)
        assert np.abs(constraint(st_.q, params)).max() < 1e-15
    assert st_.gap == pytest.approx(0.05, abs=1e-12) and st_.t == pytest.approx(0.01, abs=0)
    a.command_drs(False)
    a.advance_to(0.02 + 1e-12)
    assert a.state.gap == pytest.approx(0.01, abs=1e-12)


def test_stroke_commands_validate_at_the_boundary(params):
    a = ActuatorSim(params)
    with pytest.raises(StrokeRangeError, match=r"target stroke 0\.1 m is outside \[s_min, s_max\]"):
        a.command_stroke(0.1)
    with pytest.raises(InputError, match=r"stroke command must be finite, got nan"):
        a.command_stroke(math.nan)
    a.command_drs(True)
    a.advance_to(0.008)  # near the open end, still at 3.5 m/s
    s_now = a.state.q[0]
    # "stop here" over 10 ms from 3.5 m/s would carry the rod past s_max before it comes back
    with pytest.raises(StrokeRangeError, match=r"would leave \[s_min, s_max\]"):
        a.command_stroke(s_now, duration=0.01)
    assert a.state.q[0] == s_now and a.mode == "stroke"  # unchanged by the refusal


def test_force_commands_and_end_stops(params):
    a = ActuatorSim(params, dt=1e-4)
    s_min, s_max = kin.stroke_limits(params)
    with pytest.raises(InputError, match=r"force command must be finite, got nan"):
        a.command_force(math.nan)
    with pytest.raises(
        InputError, match=r"force command 50000\.0 N is outside \[-20000, 20000\] N"
    ):
        a.command_force(5e4)
    # below the static holding force the flap stays on the closed stop
    a.command_force(0.9 * lagrange_force(params, s_min))
    a.advance_to(0.01)
    assert a.state.at_stop == "closed" and a.state.q[0] == s_min
    # a large force opens it onto the open stop, where it stays
    a.command_force(3000.0)
    a.advance_to(0.05)
    st_ = a.state
    assert st_.at_stop == "open" and st_.q[0] == s_max and st_.piston_force == 3000.0
    assert np.all(st_.qd == 0.0)
    # between the two static forces the flap would leave the open stop only if it pulls back
    a.command_force(0.0)
    a.advance_to(0.1)
    assert a.state.at_stop == "closed"


def test_free_flight_matches_the_forward_integrator(params):
    """Away from the stops the force mode is the fixed-step integrator of drs_model.forward,
    checked here against an independent tight solve_ivp run."""
    from scipy.integrate import solve_ivp

    from drs_model.bodies import applied_forces, mass_matrix, velocity_forces
    from drs_model.constraints import constraint_gamma, constraint_jacobian

    a = ActuatorSim(params, dt=1e-5)
    a.command_stroke(0.02)
    a.advance_to(0.02)  # at rest at 20 mm
    f = lagrange_force(params, 0.02) * 1.05  # 5 % more than holding: opens slowly
    a.command_force(f)
    t0, q0 = a.t, a.state.q

    def rhs(t, y):  # index-1 full coordinates, written here from bodies + constraints
        q, qd = y[:3], y[3:]
        m = mass_matrix(q, params)
        jac = constraint_jacobian(q, params)
        kkt = np.block([[m, jac.T], [jac, np.zeros((2, 2))]])
        r = np.concatenate(
            [
                applied_forces(q, f, params) - velocity_forces(q, qd, params),
                constraint_gamma(q, qd, params),
            ]
        )
        return np.concatenate([qd, np.linalg.solve(kkt, r)[:3]])

    ref = solve_ivp(
        rhs, (0, 0.004), np.concatenate([q0, np.zeros(3)]), method="DOP853", rtol=1e-12, atol=1e-14
    )
    a.advance_to(t0 + 0.004)
    assert a.state.at_stop is None
    assert a.state.q[0] == pytest.approx(ref.y[0, -1], abs=1e-9)
    assert a.state.q[2] == pytest.approx(ref.y[2, -1], abs=1e-8)


@given(st.floats(0.0, 0.05), st.floats(-10, 10), st.floats(-1e5, 1e5))
@settings(max_examples=60, deadline=None)
def test_scalar_kinematics_equal_the_vectorised(params, s, sd, sdd):
    q, qd, qdd = kin.kinematic_state_scalar(s, sd, sdd, params)
    ref = kin.kinematic_state(s, sd, sdd, params)
    np.testing.assert_allclose(q, ref.q, atol=1e-14)
    np.testing.assert_allclose(qd, ref.qd, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(qdd, ref.qdd, rtol=1e-10, atol=1e-6)
    back = kin.accelerations_from_flap_scalar(q, qd, qdd[2], params)
    np.testing.assert_allclose(back, ref.qdd, rtol=1e-9, atol=1e-5)


def test_force_method_virtual_work_is_still_the_fused_path(params):
    """The name "virtual-work" meant ActuatorSim's fused path before issue 17 (the node's
    force_method parameter and recorded bags still say it): it runs the same fused kernel, to the
    bit, and the other formulations agree with it."""
    sims = {m: ActuatorSim(params, force_method=m) for m in ("fused", "virtual-work", "lagrange")}
    for sim in sims.values():
        sim.command_drs(True)
        sim.advance(4)
    forces = {m: sim.state.piston_force for m, sim in sims.items()}
    assert forces["virtual-work"] == forces["fused"]
    assert forces["lagrange"] == pytest.approx(forces["fused"], rel=1e-9)


def test_bad_construction(params):
    with pytest.raises(InputError, match=r"dt must be a finite number in \(0, 0\.01\] s, got 0"):
        ActuatorSim(params, dt=0)
    with pytest.raises(InputError, match=r"method must be one of .*got 'bogus'"):
        ActuatorSim(params, force_method="bogus")


def test_trajectory_passes_its_points_at_their_times(params):
    a = ActuatorSim(params, dt=1e-3)
    a.command_trajectory([0.01, 0.02, 0.03], [0.02, 0.04, 0.01])
    seen = {}
    for _ in range(40):
        st_ = a.step()
        seen[round(st_.t, 6)] = st_
    for t, s in ((0.01, 0.02), (0.02, 0.04), (0.03, 0.01)):
        assert seen[t].q[0] == pytest.approx(s, abs=1e-12)
        assert np.abs(constraint(seen[t].q, params)).max() < 1e-14
    # C1 through the interior points: the rate there is the slope across the neighbours
    assert seen[0.01].qd[0] == pytest.approx((0.04 - kin.stroke_limits(params)[0]) / 0.02, rel=1e-9)
    assert seen[0.03].qd[0] == pytest.approx(0.0, abs=1e-12)
    assert seen[0.035].q[0] == pytest.approx(0.01, abs=1e-15)
    # the force along it is the inverse dynamics of that motion
    st_ = seen[0.015]
    assert st_.piston_force == pytest.approx(
        lagrange_force(params, *st_.q[:1], st_.qd[0], st_.qdd[0]), rel=1e-9
    )


@pytest.mark.parametrize(
    ("times", "strokes", "rates", "match"),
    [
        ([0.01, 0.01], [0.02, 0.03], None, r"times must increase strictly from > 0 s"),
        ([0.0], [0.02], None, r"times must increase strictly from > 0 s"),
        ([0.01], [0.2], None, r"stroke 0\.2 m is outside \[s_min, s_max\]"),
        ([0.01], [float("nan")], None, r"must be finite"),
        ([], [], None, r"needs 1\.\.10000 points"),
        ([0.01], [0.02], [float("inf")], r"rates must be 1 finite values"),
        # arriving at 45 mm at 2 m/s, it cannot stop at 46 mm within 10 ms without overshooting
        (
            [0.01, 0.02],
            [0.045, 0.046],
            [2.0, 0.0],
            r"leaves \[s_min, s_max\].* on its way to point 1 \(of 0\.\.1\)",
        ),
    ],
)
def test_bad_trajectories_are_refused_and_change_nothing(params, times, strokes, rates, match):
    a = ActuatorSim(params)
    before = a.state
    with pytest.raises((InputError, StrokeRangeError), match=match):
        a.command_trajectory(times, strokes, rates)
    assert a.mode == before.mode and a.state.q[0] == before.q[0]
