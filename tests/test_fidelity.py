"""The fidelity ladder (drs_model.fidelity): each rung against the next, the hydraulic rung's
limit, its energy balance and its stiff step limit. Model tests: no rclpy."""

from __future__ import annotations

import math

import kinematics_support
import numpy as np
import pytest

from drs_model import DRSParams
from drs_model import kinematics as kin
from drs_model.bodies import air_forces, kinetic_energy, potential_energy
from drs_model.compiled.scalar import compiled_or_plain
from drs_model.errors import InputError, ParameterError, StiffStepError, UnsupportedCommandError
from drs_model.fidelity import RUNGS, HydraulicParams, make_rung
from drs_model.fidelity import hydraulic_kernels as hk
from drs_model.fidelity.hydraulic_steps import CALLEES, RK4_LIMIT, STEP_METHODS, rk4_step
from drs_model.fidelity.hydraulic_vector import hydraulic_constants
from drs_model.inverse import inverse_dynamics

P = DRSParams()


def _run(rung, steps):
    out = [rung.step() for _ in range(steps)]
    return (
        np.array([st.q for st in out]),
        np.array([st.qd for st in out]),
        np.array([st.qdd for st in out]),
        np.array([st.piston_force for st in out]),
    )


# ---- kinematic == rigid positions in stroke mode ------------------------------------------------
@pytest.mark.parametrize("dt", [1e-3, 1e-4])
def test_kinematic_positions_equal_rigid_in_stroke_mode(dt):
    kinematic, rigid = make_rung("kinematic", P, dt), make_rung("rigid", P, dt)
    for rung in (kinematic, rigid):
        rung.command_drs(True)
    a, b = _run(kinematic, int(0.02 / dt)), _run(rigid, int(0.02 / dt))
    for rung in (kinematic, rigid):
        rung.command_trajectory([0.005, 0.012, 0.02], [0.03, 0.01, 0.025])
    c, d = _run(kinematic, int(0.03 / dt)), _run(rigid, int(0.03 / dt))
    for x, y in ((a, b), (c, d)):
        np.testing.assert_array_equal(x[0], y[0])  # q
        np.testing.assert_array_equal(x[1], y[1])  # qd
        np.testing.assert_array_equal(x[2], y[2])  # qdd
        assert np.all(np.isnan(x[3])) and np.all(np.isfinite(y[3]))
    # and the positions close the loop: the kinematic rung is no looser than the rigid one
    assert np.max(np.abs(kin.gap(c[0], P) - kin.gap_from_flap_angle(c[0][:, 2], P))) < 1e-15


def test_kinematic_samples_are_the_stepped_strokes_into_a_new_array_or_in_place():
    """``KinematicRung.samples`` at the times of the next steps (a trajectory of three points
    in force) gives the strokes stepping gives, into a new array or into ``out``; a view into a
    larger array is written in place and nothing around it changes."""
    # the steps' times, whatever force the points need (limit_moves off)
    rung, stepped = (make_rung("kinematic", P, 1e-3, limit_moves=False) for _ in range(2))
    for r in (rung, stepped):
        r.command_trajectory([0.005, 0.012, 0.02], [0.03, 0.01, 0.025])
    times = rung.t + 1e-3 * np.arange(1, 31)
    expected = np.array([stepped.step().q[0] for _ in range(30)])
    np.testing.assert_allclose(rung.samples(times), expected, rtol=0, atol=1e-15)
    whole = np.full(40, -1.0)
    assert rung.samples(times, whole[5:35]) is not None
    np.testing.assert_allclose(whole[5:35], expected, rtol=0, atol=1e-15)
    assert np.all(whole[:5] == -1.0) and np.all(whole[35:] == -1.0)


def test_kinematic_refuses_forces():
    rung = make_rung("kinematic", P)
    with pytest.raises(UnsupportedCommandError, match="'kinematic' rung cannot represent a force"):
        rung.command_force(100.0)
    with pytest.raises(UnsupportedCommandError, match="supply loss"):
        rung.lose_supply()
    assert rung.mode == "hold"


# ---- quasi-static == rigid where the accelerations vanish ----------------------------------------
@pytest.mark.parametrize("s", np.linspace(kin.stroke_limits(P)[0], kin.stroke_limits(P)[1], 7))
def test_quasi_static_force_equals_rigid_at_rest(s):
    qs, rigid = make_rung("quasi-static", P), make_rung("rigid", P)
    f_qs, f_rigid = qs.reset(s=s).piston_force, rigid.reset(s=s).piston_force
    # an independent formulation: Newton-Euler with every reaction, at rest
    ne = inverse_dynamics(kin.kinematic_state(s, 0.0, 0.0, P), P, method="newton-euler")
    assert f_qs == pytest.approx(f_rigid, rel=1e-12, abs=1e-9)
    assert f_qs == pytest.approx(float(np.ravel(ne.piston_force)[0]), rel=1e-9)


def test_quasi_static_force_equals_rigid_in_the_hold_and_differs_in_the_move():
    dt = 1e-4
    qs, rigid = make_rung("quasi-static", P, dt), make_rung("rigid", P, dt)
    for rung in (qs, rigid):
        rung.command_drs(True)
    a, b = _run(qs, 300), _run(rigid, 300)
    at_rest = (a[1][:, 0] == 0.0) & (a[2][:, 0] == 0.0)
    assert at_rest.sum() > 150  # the hold after the 10 ms opening
    np.testing.assert_allclose(a[3][at_rest], b[3][at_rest], rtol=1e-12)
    # where the rod accelerates the statics miss the inertia: the peak is the rigid's alone
    assert np.max(np.abs(b[3] - a[3])) > 1e4


def test_quasi_static_force_command_goes_to_the_balance_or_the_stop():
    """The static force falls as the flap opens (1003 N closed, 322 N open), so a balance is
    unstable: the exact static force holds the rod where it is, any other sends it to a stop."""
    qs = make_rung("quasi-static", P)
    s_min, s_max = kin.stroke_limits(P)
    mid = 0.5 * (s_min + s_max)
    qs.reset(s=mid)
    force = qs.static_force(mid)
    assert qs.static_force(s_min) > force > qs.static_force(s_max)
    qs.command_force(force)
    st = qs.step()
    assert st.q[0] == mid and st.at_stop is None and st.piston_force == force
    qs.command_force(force + 10.0)
    assert qs.step().at_stop == "open"
    qs.command_force(force - 10.0)  # still above the open stop's static force: stays open
    assert qs.step().at_stop == "open"
    qs.command_force(0.0)  # no piston force: the air load closes the flap at once
    assert qs.step().at_stop == "closed"
    qs.command_force(force + 10.0)  # below the closed stop's static force: stays closed
    assert qs.step().at_stop == "closed"


# ---- the hydraulic rung -------------------------------------------------------------------------
def _ideal(beta: float) -> HydraulicParams:
    """Stiff oil at ``beta`` without entrained air, an ideal valve (linear flow law, no spool
    lag, 20x the flow so it never saturates on the manoeuvre), no friction, no leak, no relief; a
    loop gain well under the oil column's frequency at every beta (200 rad/s crossover)."""
    return HydraulicParams(
        flow_law="linear",
        spool_time_constant=0.0,
        viscous_friction=0.0,
        coulomb_friction=0.0,
        breakaway_friction=0.0,
        leak_across_piston=0.0,
        relief_flow_gain=0.0,
        valve_rated_flow=20 * 7.5 / 60000,
        bulk_modulus=beta,
        position_gain=10.0,
        entrained_air_fraction=0.0,
    )


def _limit_errors(beta: float) -> tuple[float, float]:
    dt = 1e-4
    hyd = make_rung("hydraulic", P, dt, hydraulic=_ideal(beta), method="rk4")
    rigid = make_rung("rigid", P, dt)
    for rung in (hyd, rigid):
        rung.command_drs(True)
    a, b = _run(hyd, 200), _run(rigid, 200)
    return float(np.max(np.abs(a[0][:, 0] - b[0][:, 0]))), float(np.max(np.abs(a[3] - b[3])))


def test_hydraulic_tends_to_rigid_with_stiff_oil_and_an_ideal_valve():
    """The convergence test: over the 10 ms opening and 10 ms of hold, the stroke and force
    errors against the rigid rung fall as beta^-rate; measured 1.0-1.7 (stroke) and 0.8-1.2
    (force) per decade between 1e10 and 1e13 Pa (docs/fidelity.md)."""
    betas = np.array([1e10, 1e11, 1e12, 1e13])
    errors = np.array([_limit_errors(b) for b in betas])
    rate_s = -np.polyfit(np.log10(betas), np.log10(errors[:, 0]), 1)[0]
    rate_f = -np.polyfit(np.log10(betas), np.log10(errors[:, 1]), 1)[0]
    assert np.all(np.diff(errors[:, 0]) < 0) and np.all(np.diff(errors[:, 1]) < 0)
    assert rate_s > 0.8 and rate_f > 0.7, (rate_s, rate_f, errors)
    assert errors[-1, 0] < 2e-7  # m, against a 46 mm stroke
    assert errors[-1, 1] < 0.01 * 25413.0  # N, against the 25.4 kN peak


def test_hydraulic_energy_balance():
    """Over a move to mid-stroke and back with the default valve, friction, leak and stops: the
    supply's work = valve, leak and relief losses + the oil's compression work + friction + what
    the stops take + the change of kinetic and potential energy - the air's work. Mechanical
    energies from drs_model.bodies (mass matrix, potential), the air's work from the air force
    and G3's velocity, the compression work from finite differences of the pressures: none from
    the rung's own right-hand side. Tolerance 1e-5 of the supply's work (trapezoidal sums at
    0.1 ms; measured 6e-8 of 183 J). Without entrained air (its work and the cavities':
    test_fidelity_low_pressure)."""
    dt = 1e-4
    hp = HydraulicParams(entrained_air_fraction=0.0)
    rung = make_rung("hydraulic", P, dt, hydraulic=hp, method="rk4")
    c, h = rung._consts
    rows = []

    def sample():
        y = rung.y
        st = rung.state
        s_ref, v_ref = rung._reference(rung.t)
        powers = hk.power_balance(
            *y, hk.MODE_STROKE, s_ref, v_ref, 0.0, hp.supply_pressure, 0.0, tuple(c), tuple(h)
        )
        rows.append((rung.t, *powers, *st.q, *st.qd, y[2], y[3]))

    sample()
    rung.command_stroke(0.03, 0.03)
    for _ in range(700):
        rung.step()
        sample()
        if len(rows) == 400:
            rung.command_stroke(0.01, 0.02)
    a = np.array(rows)
    t = a[:, 0]
    supply, valve, leak, relief, _, _, friction, stop, cavitation = a[:, 1:10].T
    q, qd, pa, pb = a[:, 10:13], a[:, 13:16], a[:, 16], a[:, 17]
    assert not np.any(cavitation)
    va = hp.dead_volume_piston_side + hp.piston_area * (q[:, 0] - rung.s_min)
    vb = hp.dead_volume_rod_side + hp.rod_side_area * (rung.s_max - q[:, 0])
    compression = (pa * va * np.gradient(pa, t) + pb * vb * np.gradient(pb, t)) / hp.bulk_modulus
    drag, down = air_forces(q[:, 2], P)
    v_g3 = kinematics_support.point_velocities(q, qd, P, ("G3",))["G3"]
    air = drag * v_g3[:, 0] - down * v_g3[:, 1]
    energy = kinetic_energy(q, qd, P) + potential_energy(q, P)

    def work(x):
        return float(np.trapezoid(x, t))

    w_supply = work(supply)
    losses = work(valve) + work(leak) + work(relief) + work(friction) - work(stop)
    budget = losses + work(compression) + (energy[-1] - energy[0]) - work(air)
    assert w_supply > 1.0  # J: the move does real work
    assert abs(w_supply - budget) < 1e-5 * w_supply, (w_supply, budget)
    assert work(valve) > 0.1 * w_supply  # the valve is where most of it goes


def test_explicit_step_above_the_stiff_limit_is_refused():
    rung = make_rung("hydraulic", P, 0.005, method="rk4", substep=0.005)
    before = rung.y
    with pytest.raises(StiffStepError, match=r"sub-step of 0\.005 s exceeds the stability limit"):
        rung.step()
    np.testing.assert_array_equal(rung.y, before)  # refused, not taken
    assert rung.t == 0.0 and rung.steps == 0


def test_the_stiff_limit_is_where_rk4_blows_up():
    """The estimate behind the refusal is sound and not idle: from a disturbed equilibrium, RK4
    sub-steps at 0.9x the limit settle and at 8x they do not: the oscillation grows until the
    chamber cavitates (the vapour pressure bounds it from below) or the state is no longer
    finite (what the refusal prevents).
    The estimate counts the valve fully open (it may open within a step), so at rest it is 2-5x
    below the measured blow-up."""
    rung = make_rung("hydraulic", P, 1e-3)
    rung.reset(s=0.005)
    c, h = rung._consts
    y0 = rung.y
    y0[2] += 5e5  # a 5 bar disturbance rings the oil column
    rate = hk.stiffest_rate(y0[0], y0[1], y0[2], y0[3], y0[4], 210e5, tuple(c), tuple(h))

    def run(factor):
        y, step = y0.copy(), factor * RK4_LIMIT / rate
        for _ in range(int(0.01 / step)):
            y = rk4_step(
                y,
                0.0,
                0.005,
                0.0,
                0.005,
                0.0,
                0.005,
                0.0,
                0.0,
                210e5,
                210e5,
                0.0,
                step,
                tuple(c),
                tuple(h),
            )
            if not np.all(np.isfinite(y)) or abs(y[2]) > 1e10:
                return math.inf
        return abs(y[2] - rung.y[2])

    assert run(0.9) < 5e5
    assert run(8.0) > 1e7  # Pa: 20x the disturbance


@pytest.mark.parametrize("method", ["ros2", "linearly-implicit-euler", "rk4"])
def test_every_method_runs_the_manoeuvre_and_agrees(method):
    dt = 1e-3
    ref = make_rung("hydraulic", P, dt, method="rk4")
    rung = make_rung("hydraulic", P, dt, method=method)
    for r in (ref, rung):
        r.command_drs(True)
    a, b = _run(ref, 80), _run(rung, 80)
    tol = {"ros2": 2e-4, "linearly-implicit-euler": 1e-3, "rk4": 1e-5}[method]
    assert np.max(np.abs(a[0][:, 0] - b[0][:, 0])) < tol
    assert b[0][-1, 0] == pytest.approx(rung.s_max, abs=1e-5)  # opened, slower than 10 ms
    assert a[0][9, 0] < 0.5 * rung.s_max  # the valve cannot follow the seed's 10 ms opening


def _closing_time(rung, steps=400):
    rung.command_drs(True)
    for _ in range(80):
        rung.step()
    t0 = rung.t
    rung.lose_supply()
    for _ in range(steps):
        st = rung.step()
        if st.at_stop == "closed" or st.q[0] < rung.s_min + 1e-6:
            return st.t - t0
    return math.inf


def test_supply_loss_closes_the_flap_on_every_rung_with_forces():
    times = {name: _closing_time(make_rung(name, P, 1e-3)) for name in RUNGS if name != "kinematic"}
    assert times["quasi-static"] == pytest.approx(1e-3)  # at once: the first step
    assert 0.005 < times["rigid"] < 0.05  # the air load against the flap's inertia
    assert times["rigid"] < times["hydraulic"] < 0.4  # the oil must leave through the valve


def test_supply_loss_without_the_close_command_locks_the_hydraulic_flap():
    rung = make_rung("hydraulic", P, 1e-3)
    rung.command_drs(True)
    for _ in range(80):
        rung.step()
    s_open = rung.state.q[0]
    rung.lose_supply(close=False)
    for _ in range(100):
        st = rung.step()
    assert s_open - st.q[0] < 1e-3  # the valve near null traps the oil: < 1 mm in 100 ms
    assert st.supply_pressure == rung.hydraulic.return_pressure


@pytest.mark.parametrize("method", sorted(STEP_METHODS))
def test_compiled_steps_equal_the_plain_python(method):
    """numba's build of each step (what the rung runs) against the plain function: a stale numba
    cache (a kernel edited, ``make clean-cache`` not run) fails here."""
    rung = make_rung("hydraulic", P, 1e-3)
    rung.reset(s=0.01)
    c, h = rung._consts
    y = rung.y
    y[1], y[2], y[4] = -3.0, y[2] + 2e5, 0.3
    args = (0.0, 0.012, 0.5, 0.0121, 0.5, 0.0122, 0.5, 0.0, 210e5, 200e5, 0.0, 1e-4)
    plain = STEP_METHODS[method][0](y, *args, tuple(c), tuple(h))
    built = compiled_or_plain(STEP_METHODS[method][0], CALLEES)(y, *args, c, h)
    np.testing.assert_allclose(built, plain, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(plain - y)) > 1.0  # the step moved the state


def test_hydraulic_params_refuse_bad_values():
    with pytest.raises(ParameterError, match="rod_diameter must be < bore_diameter"):
        HydraulicParams(rod_diameter=0.02)
    with pytest.raises(ParameterError, match="flow_law must be one of"):
        HydraulicParams(flow_law="magic")
    with pytest.raises(ParameterError, match="bulk_modulus must be > 0"):
        HydraulicParams(bulk_modulus=0.0)
    with pytest.raises(ParameterError, match="unknown hydraulic parameter"):
        HydraulicParams().replace(bulk=1.0)
    # a field no formula read is gone: giving it is an error that names it, never ignored
    with pytest.raises(ParameterError, match="oil_density: .* no formula"):
        HydraulicParams(oil_density=850.0)
    with pytest.raises(ParameterError, match="oil_density: .* no formula"):
        HydraulicParams().replace(oil_density=850.0)
    # a value the user gives is the value used, even when it equals the derived default
    hp = HydraulicParams(valve_port_ratio=0.75)  # = the default bore's area ratio
    assert hp.port_ratio == 0.75 and hp.replace(bore_diameter=0.02).port_ratio == 0.75
    assert HydraulicParams().replace(bore_diameter=0.02).port_ratio == pytest.approx(0.84)
    assert hydraulic_constants(HydraulicParams(), P)[hk.S_MAX] == kin.stroke_limits(P)[1]


def test_make_rung_names_the_rungs():
    assert list(RUNGS) == ["kinematic", "quasi-static", "rigid", "hydraulic"]
    with pytest.raises(InputError, match="fidelity must be one of"):
        make_rung("exact", P)
    for name in RUNGS:
        assert make_rung(name, P).state.rung == name


@pytest.mark.parametrize("name", ["kinematic", "quasi-static"])
def test_advance_many_steps_equals_one_at_a_time(name):
    """The rungs whose state is the commanded path's evaluate only the last of ``advance(n)``'s
    steps: the state equals, to the bit, that of the same steps taken one at a time, through a
    move (its middle and its end) and a trajectory; a rung that integrates would differ."""
    # the steps' states, whatever force the trajectory needs (limit_moves off)
    jumped, stepped = (make_rung(name, P, 1e-3, limit_moves=False) for _ in range(2))
    for rung in (jumped, stepped):
        rung.command_drs(True)
    for n in (3, 4, 7, 1, 20):  # ends mid-move, then past the move's end
        jumped.advance(n)
        for _ in range(n):
            stepped.advance(1)
        assert jumped.sample() == pytest.approx(stepped.sample(), rel=0, abs=0, nan_ok=True)
        assert jumped.steps == stepped.steps
    for rung in (jumped, stepped):
        rung.command_trajectory([0.004, 0.011], [rung.s_min + 1e-3, rung.s_max])
    jumped.advance(9)
    for _ in range(9):
        stepped.advance(1)
    a, b = jumped.state, stepped.state
    assert (a.t, a.mode) == (b.t, b.mode)
    np.testing.assert_array_equal(a.piston_force, b.piston_force)
    for x, y in ((a.q, b.q), (a.qd, b.qd), (a.qdd, b.qdd)):
        np.testing.assert_array_equal(x, y)
