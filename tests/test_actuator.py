"""The actuator simulation (model only): modes, commands, end stops, scalar kinematics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from trajectory_support import scalar_segments

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
        InputError, match=r"force command 50000\.0 N is outside \[-30000, 30000\] N"
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

    a = ActuatorSim(params, dt=1e-5)
    a.command_stroke(0.02)
    a.advance_to(0.02)  # at rest at 20 mm
    f = lagrange_force(params, 0.02) * 1.05  # 5 % more than holding: opens slowly
    a.command_force(f)
    t0, q0 = a.t, a.state.q
    rhs = _index1_rhs(params, f)

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


def test_each_force_method_runs_its_own_formulation(params):
    """ "fused" runs the fused closed form (FusedInverseDynamics) and "virtual-work" the
    virtual-work formulation (d'Alembert along dq/dpsi3), each to the bit on the state it
    reached; the two are different computations (their round-off differs on some step of the
    opening) that agree to 1e-9 relative, as do the other formulations."""
    from drs_model.inverse import FusedInverseDynamics

    fused = FusedInverseDynamics.from_params(params)
    names = ("fused", "virtual-work", "lagrange")
    sims = {m: ActuatorSim(params, force_method=m) for m in names}
    for sim in sims.values():
        sim.command_drs(True)
    bit_different = 0
    for _ in range(10):  # the opening's first 10 ms, through the peak force
        forces = {}
        for m, sim in sims.items():
            sim.step()
            st = sim.state
            forces[m] = st.piston_force
            if m == "fused":
                expected = fused.force(float(st.q[0]), float(st.qd[0]), float(st.qdd[0]))
            else:
                res = inverse_dynamics((st.q[None], st.qd[None], st.qdd[None]), params, m)
                expected = float(np.asarray(res.piston_force).ravel()[0])
            assert forces[m] == expected, m
        bit_different += forces["virtual-work"] != forces["fused"]
        for m in names[1:]:
            assert forces[m] == pytest.approx(forces["fused"], rel=1e-9, abs=1e-9), m
    assert bit_different > 0  # not the fused path under another name


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


# ---- force mode at every allowed physics rate: the stop follows the motion -----------------------
RATES_DT = (0.01, 0.005, 0.002, 0.001)


def _index1_rhs(params, force):
    """Index-1 full coordinates from bodies + constraints (independent of the psi3 kernels the
    actuator steps): ``y = [q, qd]``."""
    from drs_model.bodies import applied_forces, mass_matrix, velocity_forces
    from drs_model.constraints import constraint_gamma, constraint_jacobian

    def rhs(t, y):
        q, qd = y[:3], y[3:]
        m = mass_matrix(q, params)
        jac = constraint_jacobian(q, params)
        kkt = np.block([[m, jac.T], [jac, np.zeros((2, 2))]])
        r = np.concatenate(
            [
                applied_forces(q, force, params) - velocity_forces(q, qd, params),
                constraint_gamma(q, qd, params),
            ]
        )
        return np.concatenate([qd, np.linalg.solve(kkt, r)[:3]])

    return rhs


def reference_contacts(params, q0, qd0, force, horizon):
    """Contacts ``[(stop, t), ...]`` [s from the start] of the flap under a constant piston
    force by a tight solve_ivp (DOP853, rtol 1e-10) with events at the stops. A contact is
    perfectly inelastic; if the force then pulls the flap away (its free acceleration at rest
    on the stop points away), the run goes on from rest there, else it ends resting on it.
    Returns the contacts and the stop it rests on at the end (or None)."""
    from scipy.integrate import solve_ivp

    s_min, s_max = kin.stroke_limits(params)
    rhs = _index1_rhs(params, force)

    def closed(t, y):
        return y[0] - s_min

    def opened(t, y):
        return y[0] - s_max

    closed.terminal = opened.terminal = True
    closed.direction, opened.direction = -1, 1
    contacts, t0, y0 = [], 0.0, np.concatenate([q0, qd0])
    while t0 < horizon and len(contacts) < 10:
        sol = solve_ivp(
            rhs, (t0, horizon), y0, method="DOP853", rtol=1e-10, atol=1e-12, events=(closed, opened)
        )
        hits = [
            (sol.t_events[i][0], name)
            for i, name in enumerate(("closed", "open"))
            if sol.t_events[i].size
        ]
        if not hits:
            return contacts, None
        t_c, stop = min(hits)
        contacts.append((stop, t_c))
        q_stop = kin.solve_position(s_min if stop == "closed" else s_max, params)
        sdd = rhs(t_c, np.concatenate([q_stop, np.zeros(3)]))[3]
        if (sdd <= 0.0) if stop == "closed" else (sdd >= 0.0):
            return contacts, stop  # the force holds it on the stop
        t0, y0 = t_c, np.concatenate([q_stop, np.zeros(3)])
    return contacts, None


def run_force(params, dt, force, horizon, s0=None, setup=None):
    """Step an actuator under ``force`` from rest at ``s0`` (or after ``setup(sim)``) until
    ``horizon`` [s after the command]; returns the command state and the step states."""
    a = ActuatorSim(params, dt=dt)
    if setup is not None:
        setup(a)
    elif s0 is not None:
        a.reset(s=s0)
    start = a.state
    a.command_force(force)
    states = [a.step() for _ in range(int(round(horizon / dt)))]
    return start, states


def check_against_reference(params, dt, start, states, force, horizon):
    s_min, s_max = kin.stroke_limits(params)
    contacts, resting = reference_contacts(params, start.q, start.qd, force, horizon + 0.011)
    for st_ in states:  # every state in the working stroke, on the constraint manifold
        assert s_min <= st_.q[0] <= s_max
        assert np.abs(constraint(st_.q, params)).max() < 1e-12
    first = next((st_ for st_ in states if st_.at_stop is not None), None)
    if first is None:
        assert not contacts or contacts[0][1] > horizon - dt, (dt, contacts)
        return contacts, None
    t_sim = first.t - start.t
    near = [t for stop, t in contacts if stop == first.at_stop and abs(t - t_sim) <= dt * 1.000001]
    assert near, (dt, first.at_stop, t_sim, contacts)
    if resting is not None and contacts[-1][1] < horizon - dt:
        assert states[-1].at_stop == resting and np.all(states[-1].qd == 0.0)
    return contacts, first


@pytest.mark.parametrize("dt", RATES_DT)
@pytest.mark.parametrize(
    ("force", "s0", "stop"),
    [(20000.0, None, "open"), (-5000.0, 0.046, "closed")],
    ids=["+20kN-from-closed", "-5kN-from-open"],
)
def test_a_force_lands_the_flap_on_the_stop_it_drives_it_to(params, dt, force, s0, stop):
    """+20 kN opens the flap from the closed stop, -5 kN closes it from 46 mm: at 100 Hz to
    1 kHz the flap ends on that stop (never the other), reached within one step of the
    reference's contact time (4.48 ms and 5.60 ms), and no step raises."""
    start, states = run_force(params, dt, force, 0.03, s0=s0)
    contacts, first = check_against_reference(params, dt, start, states, force, 0.03)
    assert first is not None and first.at_stop == stop and contacts[0][0] == stop
    assert all(st_.at_stop == stop for st_ in states[states.index(first) :])
    s_stop = kin.stroke_limits(params)[0 if stop == "closed" else 1]
    assert states[-1].q[0] == s_stop and states[-1].piston_force == force


@given(
    force=st.floats(-20000.0, 20000.0),
    frac=st.floats(0.02, 0.98),
    dt=st.sampled_from(RATES_DT),
)
@settings(max_examples=25, deadline=None)
def test_force_mode_follows_the_reference_at_low_rates(params, force, frac, dt):
    """Any force from rest anywhere in the stroke: the first stop the flap is seen on is one
    the reference reaches within one step of that time; no step raises; every state stays in
    [s_min, s_max]."""
    s_min, s_max = kin.stroke_limits(params)
    s0 = s_min + frac * (s_max - s_min)
    start, states = run_force(params, dt, force, 0.03, s0=s0)
    check_against_reference(params, dt, start, states, force, 0.03)


@pytest.mark.parametrize("dt", RATES_DT)
def test_a_flap_thrown_onto_the_open_stop_leaves_it_within_the_step(params, dt):
    """Thrown open at 4.3 m/s (a 20 ms opening move, half done) with the force then cut to 0 N:
    the flap reaches the open stop 5.50 ms later (reference), stops there, and the load pulls
    it straight back: the rest of that step goes on from the stop (the flap is already off it
    at the step's end), the stroke then follows the reference run from rest on the open stop
    to 1e-5 m (RK4 at <= 1 ms steps: < 1e-6 m measured; staying on the stop until the step's
    end instead costs > 1 mm), and the flap lands on the closed stop within one step of the
    reference's time."""
    from scipy.integrate import solve_ivp

    s_max = kin.stroke_limits(params)[1]

    def setup(a):
        a.command_stroke(s_max, duration=0.02)
        a.advance_to(0.01)

    start, states = run_force(params, dt, 0.0, 0.04, setup=setup)
    contacts, first = check_against_reference(params, dt, start, states, 0.0, 0.04)
    assert [c[0] for c in contacts] == ["open", "closed"]
    assert first.at_stop == "closed" and states[-1].at_stop == "closed"
    (_, t_open), (_, t_closed) = contacts
    y0 = np.concatenate([kin.solve_position(s_max, params), np.zeros(3)])
    ref = solve_ivp(
        _index1_rhs(params, 0.0),
        (t_open, t_closed),
        y0,
        method="DOP853",
        rtol=1e-10,
        atol=1e-12,
        dense_output=True,
    )
    free = [st_ for st_ in states if t_open < st_.t - start.t < t_closed]
    assert free and all(st_.at_stop is None for st_ in free)
    dev = max(abs(st_.q[0] - ref.sol(st_.t - start.t)[0]) for st_ in free)
    assert dev < 1e-5, dev


def test_force_mode_is_deterministic_through_contacts(params):
    """Same commands, same bits (the node's bags are re-run bit-exactly), at 100 Hz where every
    step is sub-stepped and contacts are searched."""

    def run():
        a = ActuatorSim(params, dt=0.01)
        a.reset(s=0.046)
        out = []
        for f in (-5000.0, 20000.0, 0.0, 900.0, -20000.0):
            a.command_force(f)
            for _ in range(4):
                st_ = a.step()
                out.append((*st_.q, *st_.qd, *st_.qdd, st_.piston_force, st_.at_stop))
        return out

    assert run() == run()


def _force_run(params, frac: float, cmds, reinitialise: bool, dt: float = 1e-3):
    """Force commands ``(force [N], steps)`` from rest at ``frac`` of the stroke: each step's
    state as bytes, and how many commands found the flap moving in force mode. With
    ``reinitialise`` those commands act as every force command did before: the integrator
    re-initialised from the flap's state (``reset``, with its constraint checks)."""
    s_min, s_max = kin.stroke_limits(params)
    a = ActuatorSim(params, dt=dt)
    a.reset(s=s_min + frac * (s_max - s_min))
    out, moving = [], 0
    for force, steps in cmds:
        m = a.motion
        moving += m.mode == "force" and m.at_stop is None
        if reinitialise and m.mode == "force" and m.at_stop is None:
            a._stepper.reset(psi3=m.q[2], psi3_dot=m.qd[2], t=m.t)
            a._force_cmd = a._force = force
            m.hold_force_mode()
        else:
            a.command_force(force)
        for _ in range(steps):
            st_ = a.step()
            values = (st_.t, *st_.q, *st_.qd, *st_.qdd, st_.piston_force)
            out.append((np.array(values, dtype=float).tobytes(), st_.at_stop))  # -0.0 too
    return out, moving


@settings(max_examples=40, deadline=None)
@given(
    st.floats(min_value=0.05, max_value=0.95),
    st.lists(
        st.tuples(st.floats(min_value=-4000.0, max_value=4000.0), st.integers(1, 6)),
        min_size=2,
        max_size=6,
    ),
    st.sampled_from([1e-3, 4e-3]),  # 4 ms: the steps that cross a stop are split
)
def test_a_force_command_in_force_mode_goes_on_from_the_integrator_s_state(params, frac, cmds, dt):
    """A new force while the flap moves under an earlier one takes the integrator's state as it
    is (``restore``); the reference re-initialises the integrator from the flap's state each
    time, as every force command did before: the same bits, contacts included."""
    assert _force_run(params, frac, cmds, False, dt) == _force_run(params, frac, cmds, True, dt)


def test_force_commands_that_find_the_flap_moving_take_the_same_path_bit_for_bit(params):
    """The case above made certain: small forces from mid-stroke, the flap moving at each."""
    cmds = [(500.0, 2), (-500.0, 2), (800.0, 2), (0.0, 3)]
    new, moving = _force_run(params, 0.5, cmds, False)
    assert moving == 3  # every command after the first
    assert new == _force_run(params, 0.5, cmds, True)[0]


# ---- trajectories: planned outside the tick, followed by bisection -------------------------------
def _wave(params, n, dt=1e-3, period=0.5):
    s_min, s_max = kin.stroke_limits(params)
    t = dt * np.arange(1, n + 1)
    return t, 0.5 * (s_min + s_max) - 0.4 * (s_max - s_min) * np.cos(2 * np.pi * t / period)


def _states(a, n):
    return [
        (st_.t, *st_.q, *st_.qd, *st_.qdd, st_.piston_force) for st_ in (a.step() for _ in range(n))
    ]


@pytest.mark.parametrize("with_rates", [False, True])
def test_a_planned_trajectory_is_the_same_to_the_bit(params, with_rates):
    """command_trajectory(plan) and command_trajectory(times, strokes, rates) give the same
    states to the bit (the node plans outside its tick; drs-bag resimulate passes arrays),
    from a moving start (the state-dependent segments built at the command)."""
    times, strokes = _wave(params, 400)
    rates = np.gradient(strokes, times) if with_rates else None
    if rates is not None:
        rates[-1] = 0.0
    runs = []
    for planned in (False, True):
        # the first point 1 ms after a 3 m/s start: far beyond force_limit, a path all the same
        a = ActuatorSim(params, dt=1e-3, limit_moves=False)
        a.command_drs(True)
        a.advance(4)  # moving at ~3 m/s
        plan = a.plan_trajectory(times, strokes, rates) if planned else None
        path = (
            a.command_trajectory(plan) if planned else a.command_trajectory(times, strokes, rates)
        )
        assert len(path) == 400 and path.t_start == a.t
        runs.append(_states(a, 420))
    assert runs[0] == runs[1]
    assert runs[0][-1][1] == strokes[-1] and runs[0][-1][4] == 0.0  # settled at the last point


def _reference_refuses(params, times, strokes, rates, s0):
    """The segment-by-segment check (what command_trajectory did before plans): any segment's
    path, sampled at 65 instants, outside [s_min, s_max] by more than 1e-12 m."""
    s_min, s_max = kin.stroke_limits(params)
    for seg in scalar_segments(times, strokes, rates, s0):
        path = seg.evaluate(np.linspace(seg.t0, seg.t1, 65))[0]
        if path.min() < s_min - 1e-12 or path.max() > s_max + 1e-12:
            return True
    return False


@given(
    n=st.integers(1, 12),
    seed=st.integers(0, 2**31),
    with_rates=st.booleans(),
    frac=st.floats(0.0, 1.0),
)
@settings(max_examples=60, deadline=None)
def test_trajectory_refusals_and_motion_match_the_segment_by_segment_build(
    params, n, seed, with_rates, frac
):
    """Random trajectories (some overshooting): refused exactly when the segment-by-segment
    build refuses (nothing changes then); accepted ones are followed at every step as the
    segment-by-segment quintics give (1e-12 m, 1e-9 m/s)."""
    s_min, s_max = kin.stroke_limits(params)
    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.003, 0.02, n))
    strokes = rng.uniform(s_min, s_max, n)
    rates = None
    if with_rates:
        rates = rng.uniform(-3.0, 3.0, n)
        rates[-1] = 0.0
    s0 = s_min + frac * (s_max - s_min)
    a = ActuatorSim(params, dt=1e-3, limit_moves=False)  # the paths, whatever force they need
    a.reset(0.0, s0)
    refuses = _reference_refuses(params, times, strokes, rates, s0)
    if refuses:
        with pytest.raises(StrokeRangeError, match=r"leaves \[s_min, s_max\]"):
            a.command_trajectory(times, strokes, rates)
        assert a.mode == "hold" and a.state.q[0] == s0
        return
    a.command_trajectory(times, strokes, rates)
    ref = scalar_segments(times, strokes, rates, s0)
    for _ in range(int(times[-1] / 1e-3)):
        st_ = a.step()
        k = next(i for i, seg in enumerate(ref) if st_.t <= seg.t1 + 1e-12)
        s, v, _acc = ref[k].evaluate(st_.t)
        assert st_.q[0] == pytest.approx(float(s), abs=1e-12)
        assert st_.qd[0] == pytest.approx(float(v), abs=1e-9)


def test_a_plan_is_checked_against_the_state_it_is_commanded_in(params):
    """The plan leaves the first segment to the command: from rest on the open stop it is fine,
    from 3.5 m/s near the open end the first segment would overshoot, so that command is
    refused (naming point 0, nothing changed); the same plan is then commanded from rest. A
    plan made for other parameters, or given with arrays, is refused."""
    from drs_model.params import from_dict
    from drs_model.profile import plan_trajectory

    s_min, s_max = kin.stroke_limits(params)
    plan = plan_trajectory(params, [0.01, 0.03], [s_max - 0.006, 0.02])
    a = ActuatorSim(params, dt=1e-3)
    a.command_drs(True)
    a.advance(8)
    before = a.state
    with pytest.raises(StrokeRangeError, match=r"on its way to point 0 \(of 0\.\.1\)"):
        a.command_trajectory(plan)
    assert a.mode == "stroke" and a.state.q[0] == before.q[0] and a.state.target == s_max
    a.advance(20)  # at rest on s_max
    a.command_trajectory(plan)
    a.advance(31)
    assert a.state.q[0] == 0.02 and a.state.target == 0.02
    other = plan_trajectory(from_dict({"gap_open": 0.045}), [0.01], [0.02])
    with pytest.raises(InputError, match=r"plan was checked against \[s_min, s_max\]"):
        a.command_trajectory(other)
    with pytest.raises(InputError, match=r"a TrajectoryPlan alone or times and strokes"):
        a.command_trajectory(plan, [0.02])


def test_a_10000_point_trajectory_is_followed_to_its_end_from_arrays_and_from_its_plan(params):
    """The largest trajectory, commanded from arrays and from its plan, ends on its last point
    at rest, and both paths are the same step for step (what it costs the loop is measured by
    benchmarks/trajectory_cost.py, not asserted here)."""
    times, strokes = _wave(params, 10_000)
    a = ActuatorSim(params, dt=1e-3, limit_moves=False)  # its first point, 4 mm in 1 ms: 0.1 MN
    a.command_trajectory(times, strokes)
    a.advance(10_000)
    assert a.state.q[0] == pytest.approx(strokes[-1], abs=1e-15) and a.state.qd[0] == 0.0
    b = ActuatorSim(params, dt=1e-3, limit_moves=False)
    b.command_trajectory(b.plan_trajectory(times, strokes))
    a.reset()
    a.command_trajectory(times, strokes)
    for _ in range(100):
        a.advance(100)
        b.advance(100)
        assert b.state.q[0] == a.state.q[0] and b.state.qd[0] == a.state.qd[0]
