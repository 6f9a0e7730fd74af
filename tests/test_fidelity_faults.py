"""Faults of the hydraulic rung and of the stroke sensor: each changes what it must and nothing
else, and a faulty run is deterministic."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drs_model import DRSParams
from drs_model.errors import InputError, ParameterError
from drs_model.fidelity import make_rung
from drs_model.fidelity.sensor_faults import SensorFaults, StrokeSensor

P = DRSParams()
T_FAULT = 0.1  # s: open at 0, the fault at 0.1 s, a close command at 0.15 s


def _run(fault=None, steps=400):
    """Open, inject ``fault(rung)`` at T_FAULT, command closed at 0.15 s; the hydraulic state
    and the stroke at every 1 ms step."""
    rung = make_rung("hydraulic", P, 1e-3)
    rung.command_stroke(rung.s_max, 0.08)
    ys, strokes = [], []
    for k in range(steps):
        if k == 100 and fault is not None:
            fault(rung)
        if k == 150:
            rung.command_stroke(rung.s_min, 0.08)
        rung.step()
        ys.append(rung.y)
        strokes.append(rung.state.q[0])
    return np.array(ys), np.array(strokes)


@pytest.fixture(scope="module")
def healthy():
    return _run()


def _before_is_identical(faulty, healthy):
    np.testing.assert_array_equal(faulty[0][:100], healthy[0][:100])


def test_a_stuck_valve_holds_the_spool_and_the_flap_ignores_the_close(healthy):
    faulty = _run(lambda r: r.stick_valve())
    _before_is_identical(faulty, healthy)
    spool = faulty[0][100:, 4]
    assert np.all(spool == spool[0])  # the spool stays where it stuck
    assert healthy[1][-1] < 1e-3 < faulty[1][-1]  # healthy closed; stuck: still near open
    assert not np.array_equal(faulty[0][100:, 2], healthy[0][100:, 2])  # pressures evolve


def test_a_leak_costs_flow_the_servo_makes_up(healthy):
    faulty = _run(lambda r: r.set_leak(2e-12))
    _before_is_identical(faulty, healthy)
    # the servo holds the stroke within 0.5 mm, by a spool held open against the leak
    assert np.max(np.abs(faulty[1] - healthy[1])) < 5e-4
    hold = slice(110, 150)
    assert np.mean(np.abs(faulty[0][hold, 4])) > np.mean(np.abs(healthy[0][hold, 4])) + 1e-3
    # the leak lowers the chamber pressures it drains
    assert np.mean(faulty[0][hold, 3]) < np.mean(healthy[0][hold, 3])


def test_a_jammed_flap_stays_open(healthy):
    """5 kN of extra friction is more than the cylinder (4.2 kN at 210 bar) and the air load can
    overcome: the close command moves the valve, not the flap."""
    faulty = _run(lambda r: r.jam(5000.0))
    _before_is_identical(faulty, healthy)
    assert healthy[1][-1] < 1e-3 and faulty[1][-1] > 0.045
    assert np.min(faulty[0][150:, 4]) < -0.9  # the servo asks for closing at full spool


def test_a_supply_ramp_closes_sooner_than_a_step():
    """With the controller's close command at the loss, what is left of a ramping supply drives
    the rod in through the valve: the flap closes sooner than on the air load alone."""

    def close_time(ramp):
        rung = make_rung("hydraulic", P, 1e-3)
        rung.command_drs(True)
        rung.advance(100)
        rung.lose_supply(ramp)
        for k in range(600):
            if rung.step().q[0] < rung.s_min + 1e-4:
                return k
        return math.inf

    step, ramp = close_time(0.0), close_time(0.2)
    assert ramp < step < math.inf


def test_fault_values_are_checked():
    rung = make_rung("hydraulic", P)
    with pytest.raises(InputError, match=r"leak must be a finite number >= 0, got -1"):
        rung.set_leak(-1.0)
    with pytest.raises(InputError, match=r"jam friction must be a finite number >= 0, got nan"):
        rung.jam(math.nan)
    with pytest.raises(ParameterError, match=r"dropout must be in \[0, 1\]"):
        SensorFaults(dropout=1.5)
    with pytest.raises(ParameterError, match=r"seed must be an integer >= 0"):
        SensorFaults(seed=-3)


# ---- the sensor ---------------------------------------------------------------------------------
def _readings(faults, truth, t0=0.0):
    sensor = StrokeSensor(faults)
    return np.array([sensor.read(t0 + 1e-3 * k, k, s) for k, s in enumerate(truth)])


TRUTH = np.linspace(0.0002, 0.046, 2000)


def test_bias_adds_exactly_and_nothing_else():
    np.testing.assert_array_equal(_readings(SensorFaults(bias=1e-3), TRUTH), TRUTH + 1e-3)
    np.testing.assert_array_equal(_readings(SensorFaults(), TRUTH), TRUTH)


def test_noise_has_its_deviation_and_repeats_with_its_seed():
    a = _readings(SensorFaults(noise=1e-4, seed=7), TRUTH) - TRUTH
    b = _readings(SensorFaults(noise=1e-4, seed=7), TRUTH) - TRUTH
    c = _readings(SensorFaults(noise=1e-4, seed=8), TRUTH) - TRUTH
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    # 2000 samples: the sample deviation within 5 % of 1e-4 (its standard error is 1.6 %)
    assert np.std(a) == pytest.approx(1e-4, rel=0.05) and abs(np.mean(a)) < 1e-5
    # a step's draw depends on (seed, step) alone: read from step 1000 on, the same values
    sensor = StrokeSensor(SensorFaults(noise=1e-4, seed=7))
    late = [
        sensor.read(1.0 + 1e-3 * k, 1000 + k, TRUTH[1000 + k]) - TRUTH[1000 + k] for k in range(10)
    ]
    np.testing.assert_array_equal(late, a[1000:1010])


def test_dropout_loses_its_share_of_readings():
    r = _readings(SensorFaults(dropout=0.2, seed=3), TRUTH)
    lost = np.isnan(r)
    assert lost.mean() == pytest.approx(0.2, abs=0.03)  # 2000 draws: 3 sigma is 0.027
    np.testing.assert_array_equal(r[~lost], TRUTH[~lost])


def test_a_frozen_sensor_repeats_its_last_reading():
    r = _readings(SensorFaults(frozen_from=0.5), TRUTH)
    np.testing.assert_array_equal(r[:500], TRUTH[:500])
    assert np.all(r[500:] == TRUTH[499])
