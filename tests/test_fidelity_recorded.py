"""The rungs' equations on recorded samples (drs_model.fidelity.recorded), what ``drs-bag check``
judges a run by: each against an independent statement of the same physics (the other
formulation, the friction law's limit, a round trip, the run the sensor was read in)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drs_model import DRSParams
from drs_model.fidelity import HydraulicParams, make_rung
from drs_model.fidelity.faults import RunFaults
from drs_model.fidelity.recorded import HydraulicRecord, SensorReplay, StaticForce, true_stroke
from drs_model.inverse import inverse_dynamics
from drs_model.kinematics import solve_position, stroke_limits

P = DRSParams()


def test_the_true_stroke_is_the_stroke_of_the_flap_angle():
    s_min, s_max = stroke_limits(P)
    for s in np.linspace(s_min, s_max, 7):
        psi3 = float(solve_position(s, P)[..., 2])
        assert true_stroke(psi3, P) == pytest.approx(s, abs=1e-12)


def test_the_statics_are_the_inverse_dynamics_at_rest():
    s_min, s_max = stroke_limits(P)
    static = StaticForce(P)
    for s in np.linspace(s_min, s_max, 5):
        q = solve_position(s, P)
        rest = inverse_dynamics((q, np.zeros(3), np.zeros(3)), P).piston_force
        assert static(s) == pytest.approx(float(rest), abs=1e-6)  # [N], two formulations


def test_the_rod_force_is_the_pressures_on_their_areas_less_a_jam():
    hp = HydraulicParams()
    record = HydraulicRecord(P)
    pa, pb = 80e5, 60e5
    area_a = math.pi * hp.bore_diameter**2 / 4
    area_b = math.pi * (hp.bore_diameter**2 - hp.rod_diameter**2) / 4
    # at rest: no friction, the pressures on their areas (the areas from the bore and rod)
    assert record.rod_force(pa, pb, 0.0) == pytest.approx(pa * area_a - pb * area_b, rel=1e-12)
    fast = 0.1  # [m/s]: 20 Stribeck velocities, tanh(sd / v_smooth) = 1 to 1e-17
    before = record.rod_force(pa, pb, fast)
    record.set("jam_friction_n", 100.0, 0.5)
    assert before - record.rod_force(pa, pb, fast) == pytest.approx(100.0, abs=1e-9)
    record.set("jam_friction_n", 0.0, 0.6)
    assert record.rod_force(pa, pb, fast) == before


def test_the_supply_follows_its_loss_and_ramp():
    hp = HydraulicParams()
    record = HydraulicRecord(P)
    assert record.supply_pressure(0.2) == hp.supply_pressure
    record.set("supply_loss_ramp_s", 0.05, 0.3)
    record.set("supply_loss", True, 0.3)
    mid = 0.5 * (hp.supply_pressure + hp.return_pressure)
    assert record.supply_pressure(0.325) == pytest.approx(mid, rel=1e-12)
    assert record.supply_pressure(0.4) == hp.return_pressure
    record.set("supply_loss", False, 0.5)
    assert record.supply_pressure(0.6) == hp.supply_pressure
    assert record.supply_pressure(0.525) == pytest.approx(mid, rel=1e-12)


@pytest.mark.parametrize("rung", ["kinematic", "hydraulic"])
def test_the_replayed_sensor_publishes_what_the_run_published(rung):
    """The sensor read in a run (RunFaults on the rung, faults set between steps, frozen too)
    against the replay fed the true strokes and the same faults at the same places."""
    sim = make_rung(rung, P, 1e-3)
    run = RunFaults(sim)
    replay = SensorReplay(rung, 1e-3)
    sim.command_stroke(sim.s_max, 0.2)
    script = {
        20: [("sensor.bias_m", 1e-3), ("sensor.noise_std_m", 1e-4), ("sensor.noise_seed", 11)],
        60: [("sensor.dropout", 0.3)],
        120: [("sensor.frozen", True)],
        160: [("sensor.frozen", False)],
    }
    published, replayed = [], []
    for k in range(200):
        for name, value in script.get(k, []):
            run.apply(name, value)
            replay.set(name, value)
        sim.step()
        st = sim.state
        published.append(run.published_stroke(st.t, float(st.q[0])))
        replayed.append(replay.reading(st.t, true_stroke(float(st.q[2]), P)))
    published, replayed = np.array(published), np.array(replayed)
    assert np.isnan(published).sum() > 10  # dropouts happened
    np.testing.assert_array_equal(np.isnan(replayed), np.isnan(published))
    ok = ~np.isnan(published)
    np.testing.assert_allclose(replayed[ok], published[ok], rtol=0, atol=1e-12)
    held = published[121:160]
    assert np.all(held == held[0])  # frozen, and the replay holds the same reading


def test_a_sensor_fault_set_before_any_state_acts_from_the_first():
    replay = SensorReplay("rigid", 1e-3)
    replay.set("sensor.bias_m", 2e-3)
    assert not replay.healthy
    assert replay.reading(0.0, 0.02) == pytest.approx(0.022)
    with pytest.raises(ValueError, match="not a sensor fault: 'supply_loss'"):
        replay.set("supply_loss", True)
