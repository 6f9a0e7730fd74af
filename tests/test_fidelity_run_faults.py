"""The faults set at run time (drs_model.fidelity.faults.RunFaults, the node's ``fault.*``
parameters): each changes what it must and nothing else, a fault a rung cannot model is refused
with the reason, a bad value is refused and changes nothing."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model import DRSParams
from drs_model.errors import InputError, TooStiffError, UnsupportedCommandError
from drs_model.fidelity import RUNGS, HydraulicParams, make_rung
from drs_model.fidelity.faults import (
    FAULT_RANGES,
    FAULTS,
    HYDRAULIC_ONLY,
    RunFaults,
    describe_range,
)

P = DRSParams()
K_FAULT = 100  # the step the fault is set at (the flap opening since step 0)


def _run(rung: str, faults: dict, steps: int = 250):
    """Open over 200 ms; at step K_FAULT set ``faults`` (name -> value, in order); per step the
    true state (t, stroke, flap angle, force, hydraulic y or None) and the published stroke."""
    sim = make_rung(rung, P, 1e-3)
    run = RunFaults(sim)
    sim.command_stroke(sim.s_max, 0.2)
    true, published = [], []
    for k in range(steps):
        if k == K_FAULT:
            for name, value in faults.items():
                run.apply(name, value)
        sim.step()
        st_ = sim.state
        y = sim.y if rung == "hydraulic" else None
        true.append((st_.t, st_.q[0], st_.q[2], st_.piston_force, y))
        published.append(run.published_stroke(st_.t, float(st_.q[0])))
    return true, np.array(published), run


def _true_arrays(true):
    return np.array([row[:4] for row in true])


@pytest.mark.parametrize("rung", list(RUNGS))
def test_sensor_faults_change_the_published_stroke_only(rung):
    healthy, pub_h, _ = _run(rung, {})
    faults = {
        "sensor.bias_m": 1e-3,
        "sensor.noise_std_m": 1e-4,
        "sensor.noise_seed": 7,
        "sensor.dropout": 0.2,
    }
    faulty, pub_f, _ = _run(rung, faults)
    # the simulation is untouched: every true quantity bit for bit
    np.testing.assert_array_equal(_true_arrays(faulty), _true_arrays(healthy))
    np.testing.assert_array_equal(pub_f[:K_FAULT], pub_h[:K_FAULT])
    after = pub_f[K_FAULT:]
    truth = _true_arrays(faulty)[K_FAULT:, 1]
    lost = np.isnan(after)
    # dropouts at about the set rate (150 samples, p = 0.2: 30 +- 4.9; 5 sigma)
    assert abs(lost.sum() - 0.2 * len(after)) < 5 * math.sqrt(0.2 * 0.8 * len(after))
    err = after[~lost] - truth[~lost]
    # the error is bias plus noise: its mean within 5 standard errors of 1 mm, its spread ~0.1 mm
    assert abs(err.mean() - 1e-3) < 5 * 1e-4 / math.sqrt(err.size)
    assert 0.7e-4 < err.std() < 1.3e-4


def test_the_noise_and_dropouts_are_a_function_of_seed_and_step():
    """The draws do not depend on which samples were read before: a re-run that reads every step
    and a node that reads every fourth give the same value at the same step."""
    faults = {"sensor.noise_std_m": 1e-4, "sensor.noise_seed": 3, "sensor.dropout": 0.3}
    every, _, _ = _run("rigid", {})
    a = RunFaults(make_rung("rigid", P, 1e-3))
    b = RunFaults(make_rung("rigid", P, 1e-3))
    for name, value in faults.items():
        a.apply(name, value)
        b.apply(name, value)
    read_a = [a.published_stroke(t, s) for t, s, *_ in every]
    read_b = {k: b.published_stroke(every[k][0], every[k][1]) for k in range(0, len(every), 4)}
    for k, v in read_b.items():
        assert v == read_a[k] or (math.isnan(v) and math.isnan(read_a[k]))


def test_a_frozen_sensor_repeats_the_reading_of_the_step_it_froze_at():
    healthy, _, _ = _run("rigid", {})
    faulty, pub, _ = _run("rigid", {"sensor.bias_m": 2e-3, "sensor.frozen": True})
    np.testing.assert_array_equal(_true_arrays(faulty), _true_arrays(healthy))
    # frozen at the state of step K_FAULT - 1 (the last before the fault's tick), bias included
    held = healthy[K_FAULT - 1][1] + 2e-3
    assert np.all(pub[K_FAULT:] == held)
    assert np.ptp(_true_arrays(faulty)[K_FAULT:, 1]) > 0.01  # while the flap moved on


def test_a_leak_on_the_hydraulic_rung_changes_the_pressures():
    healthy, _, _ = _run("hydraulic", {})
    faulty, _, _ = _run("hydraulic", {"leak_m3_per_s_per_pa": 2e-12})
    y_h = np.array([row[4] for row in healthy])
    y_f = np.array([row[4] for row in faulty])
    np.testing.assert_array_equal(y_f[:K_FAULT], y_h[:K_FAULT])
    # 2e-12 m^3/(s Pa) at ~100 bar: ~2 cm^3/s out of each chamber, which the servo makes up by a
    # changed spool and pressures: the pressures differ by more than round-off
    assert np.max(np.abs(y_f[K_FAULT + 5 :, 2] - y_h[K_FAULT + 5 :, 2])) > 1e3  # Pa


def test_a_stuck_valve_and_a_jam_act_on_the_hydraulic_rung():
    healthy, _, _ = _run("hydraulic", {})
    stuck, _, _ = _run("hydraulic", {"stuck_valve": True})
    spool = np.array([row[4][4] for row in stuck])[K_FAULT:]
    assert np.all(spool == spool[0])
    jammed, _, _ = _run("hydraulic", {"jam_friction_n": 5000.0})
    s_h, s_j = _true_arrays(healthy)[:, 1], _true_arrays(jammed)[:, 1]
    np.testing.assert_array_equal(s_j[:K_FAULT], s_h[:K_FAULT])
    assert np.max(np.abs(s_j - s_h)) > 1e-5  # the servo lags more against 5 kN of friction


@pytest.mark.parametrize("rung", ["kinematic", "quasi-static", "rigid"])
@pytest.mark.parametrize("name", HYDRAULIC_ONLY)
def test_a_fault_without_a_model_on_the_rung_is_refused(rung, name):
    value = True if isinstance(FAULTS[name][0], bool) else FAULT_RANGES[name][1]  # in range
    run = RunFaults(make_rung(rung, P, 1e-3))
    with pytest.raises(UnsupportedCommandError, match=f"cannot model fault {name}"):
        run.apply(name, value)
    assert run.active() == {}
    run.apply(name, FAULTS[name][0])  # the healthy value is taken on every rung


def test_supply_loss_on_rigid_is_a_zero_force_and_refused_on_kinematic():
    sim = make_rung("rigid", P, 1e-3)
    ref = make_rung("rigid", P, 1e-3)
    run = RunFaults(sim)
    for s in (sim, ref):
        s.command_stroke(s.s_max, 0.08)
        s.advance(120)
    run.apply("supply_loss", True)
    ref.command_force(0.0)  # the documented equivalent, applied by hand
    sim.advance(100)
    ref.advance(100)
    np.testing.assert_array_equal(sim.state.q, ref.state.q)
    assert sim.state.q[0] < ref.s_max - 1e-3  # the air load closes the flap
    with pytest.raises(UnsupportedCommandError, match="models no forces"):
        RunFaults(make_rung("kinematic", P, 1e-3)).apply("supply_loss", True)


def test_supply_loss_ramp_on_hydraulic_follows_the_ramp():
    sim = make_rung("hydraulic", P, 1e-3)
    run = RunFaults(sim)
    ps, pr = sim.hydraulic.supply_pressure, sim.hydraulic.return_pressure
    sim.advance(10)
    run.apply("supply_loss_ramp_s", 0.05)
    run.apply("supply_loss", True)
    t0 = sim.t
    sim.advance(25)  # half the ramp
    assert sim.state.supply_pressure == pytest.approx(ps + (pr - ps) * (sim.t - t0) / 0.05)
    sim.advance(50)
    assert sim.state.supply_pressure == pr
    run.apply("supply_loss", False)  # back, over the same ramp
    sim.advance(50)
    assert sim.state.supply_pressure == ps


@settings(max_examples=40, deadline=None)
@given(
    name=st.sampled_from(sorted(FAULTS)),
    value=st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(-5, 5),
        st.booleans(),
        st.text(max_size=3),
    ),
)
def test_a_bad_value_is_refused_and_changes_nothing(name, value):
    """Any value of the wrong kind or out of range raises InputError naming the fault; one that
    is taken is kept as the value in force."""
    sim = make_rung("hydraulic", P, 1e-3)
    run = RunFaults(sim)
    y0 = sim.y
    try:
        run.apply(name, value)
    except InputError as exc:
        assert name in str(exc)
        assert run.active() == {}
        np.testing.assert_array_equal(sim.y, y0)
        return
    assert run.values[name] == value


SENSOR_FAULTS = sorted(n for n in FAULTS if n.startswith("sensor."))


@settings(max_examples=40, deadline=None)
@given(changes=st.lists(st.tuples(st.sampled_from(SENSOR_FAULTS), st.booleans()), max_size=12))
def test_the_sensor_is_healthy_exactly_when_every_sensor_fault_is_at_its_healthy_value(changes):
    """Whatever the order of the sensor faults set and cleared, ``sensor_healthy`` (kept where a
    fault is applied) is the comparison of every sensor fault with its healthy value, and the
    stroke published is the true one exactly then; the values cannot be changed but by apply."""
    sim = make_rung("rigid", P, 1e-3)
    run = RunFaults(sim)
    faulty = {
        "sensor.bias_m": 1e-3,
        "sensor.noise_std_m": 1e-4,
        "sensor.noise_seed": 7,
        "sensor.dropout": 0.5,
        "sensor.frozen": True,
    }
    for name, set_faulty in changes:
        run.apply(name, faulty[name] if set_faulty else FAULTS[name][0])
        sim.advance(1)
        expected = all(run.values[n] == FAULTS[n][0] for n in SENSOR_FAULTS)
        assert run.sensor_healthy is expected
        if expected:
            assert run.published_stroke(sim.t, 0.01) == 0.01
    with pytest.raises(TypeError):
        run.values["sensor.bias_m"] = 1.0  # read-only: the kept answer cannot go stale


# ---- physical ranges and the rung's stiffness bound ---------------------------------------------
def _rung_for(name: str) -> str:
    return "hydraulic" if name in HYDRAULIC_ONLY or name.startswith("supply") else "rigid"


@pytest.mark.parametrize("name", sorted(FAULT_RANGES))
def test_each_fault_is_taken_at_the_edges_of_its_range_and_refused_beyond(name):
    """Both edges are taken (and act: the value in force); just beyond either edge the value is
    refused with the fault's name, its range and the value given, and nothing changes."""
    low, high, _ = FAULT_RANGES[name]
    integer = isinstance(FAULTS[name][0], int)
    for edge in (low, high):
        run = RunFaults(make_rung(_rung_for(name), P, 1e-3))
        run.apply(name, edge)
        assert run.values[name] == edge
    beyond = (low - 1, high + 1) if integer else (low - 1e-3 * (high - low), high * (1 + 1e-9))
    for value in beyond:
        run = RunFaults(make_rung(_rung_for(name), P, 1e-3))
        with pytest.raises(InputError, match=rf"fault {re.escape(name)} must be in \[") as err:
            run.apply(name, value)
        assert repr(value) in str(err.value) and describe_range(name) in str(err.value)
        assert run.active() == {}


def test_the_hydraulic_bounds_are_what_their_reasons_say():
    """The reasons of the hydraulic ranges, recomputed from the rung's documented constants:
    the jam bound is the cylinder's force at the relief pressure (within 1 %), and the leak bound
    passes 16 times the valve's rated flow at 200 bar (within 5 %)."""
    hp = HydraulicParams()
    assert FAULT_RANGES["jam_friction_n"][1] == pytest.approx(
        hp.relief_pressure * hp.piston_area, rel=0.01
    )
    flow = FAULT_RANGES["leak_m3_per_s_per_pa"][1] * 200e5
    assert flow == pytest.approx(120.0 / 60000.0, rel=0.05)
    assert flow / hp.valve_rated_flow == pytest.approx(16.0, rel=0.05)


def test_1e300_is_refused_when_set_not_stepped():
    """What once hung a node (a 1e300 N jam: ~1e300 explicit sub-steps in the next step) is
    refused by its range, and the rung itself refuses it too (its stiffness bound)."""
    sim = make_rung("hydraulic", P, 1e-3)
    run = RunFaults(sim)
    for name in ("jam_friction_n", "sensor.bias_m", "leak_m3_per_s_per_pa"):
        with pytest.raises(InputError, match=r"must be in \["):
            run.apply(name, 1e300)
    with pytest.raises(TooStiffError, match=r"too stiff for a physics step of 0\.001 s"):
        sim.jam(1e300)
    with pytest.raises(TooStiffError, match=r"above 1/2 of the cap of 1000"):
        sim.set_leak(1e-7)
    sim.advance(20)  # nothing took: the healthy rung steps on


def test_a_fault_too_stiff_for_the_step_is_refused_with_the_rung_s_reason():
    """Within its physical range, a jam the rung cannot step within its cap (here a cap of 100
    sub-steps) is refused when set, with the sub-steps it would need."""
    sim = make_rung("hydraulic", P, 1e-3, max_substeps=100)
    sim.command_drs(True)
    sim.advance(150)  # open: the stiffest place for friction (the least inertia at the rod)
    run = RunFaults(sim)
    with pytest.raises(
        TooStiffError,
        match=r"needs 3\d\d(\.\d+)? rk4 sub-steps per step, above "
        r"1/2 of the cap of 100",
    ):
        run.apply("jam_friction_n", 5000.0)
    assert run.active() == {}
    run.apply("jam_friction_n", 500.0)  # a lighter jam is taken


def counted_substeps(sim) -> list[int]:
    """Count the sub-steps of the hydraulic rung ``sim`` from now on: ``calls[0]`` of the list
    returned is the number of its sub-step calls (reset it to count afresh)."""
    calls = [0]
    substep = sim._substep

    def counted(*args):
        calls[0] += 1
        return substep(*args)

    sim._substep = counted
    return calls


def test_no_step_takes_more_sub_steps_than_the_cap():
    """Every step of a run with the stiffest faults in range counts its sub-steps (the rung's
    sub-step calls; where a stop's contact is located within one, the bisection's trial steps
    are not sub-steps: at most ``hydraulic_events.MAX_EVENTS`` per sub-step, each a bounded
    search); none exceeds ``max_substeps``; a state too stiff for the cap (oil 1e10 times
    stiffer) raises TooStiffError before any sub-step, leaving the state as it was."""
    sim = make_rung("hydraulic", P, 1e-3)
    calls = counted_substeps(sim)
    run = RunFaults(sim)
    sim.command_drs(True)
    worst = 0
    for k in range(300):
        if k == 150:
            run.apply("jam_friction_n", 5000.0)
            run.apply("leak_m3_per_s_per_pa", 1e-10)
        calls[0] = 0
        sim.advance(1)
        worst = max(worst, calls[0])
    assert 100 < worst <= sim.max_substeps == 1000

    stiff = make_rung("hydraulic", P, 1e-3, hydraulic=HydraulicParams(bulk_modulus=1.4e19))
    before = stiff.y
    with pytest.raises(TooStiffError, match=r"needs \d\.\d+e\+\d+ rk4 sub-steps, above the cap"):
        stiff.advance(1)
    np.testing.assert_array_equal(stiff.y, before)
    assert stiff.steps == 0


def test_the_sub_step_cap_counts_whole_sub_steps():
    """1 us sub-steps of a 10 us step are 10 sub-steps at every step, the cap's 10, though the
    step's length ``t1 - t0`` rounds above 10 us late in the run (first at 62.5 ms): the cap
    compares counts, not lengths; 0.9 us sub-steps are refused (11 needed)."""
    sim = make_rung("hydraulic", P, 1e-5, substep=1e-6)
    calls = counted_substeps(sim)
    sim.command_drs(True)
    lengths = []
    for _ in range(8000):
        t0 = sim.t
        sim.advance(1)
        lengths.append(sim.t - t0)
    assert sim.max_substeps == 10 and calls[0] == 10 * 8000
    # the rounding that was refused is in the run: a length comparison finds 10 too few
    assert max(lengths) / 1e-6 * (1 - 1e-12) > 10
    tight = make_rung("hydraulic", P, 1e-5, substep=0.9e-6)
    with pytest.raises(TooStiffError, match=r"needs 11\.\d+ rk4 sub-steps, above the cap of 10"):
        tight.advance(1)
