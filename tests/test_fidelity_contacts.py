"""The hydraulic rung across the thresholds where its rate jumps or bends, each crossed both
ways: the end stops' contact (its damping force jumps where it begins) and the relief valve's
setting (its flow's slope changes), against Radau on the rung's right-hand side with the
crossings located (hydraulic_reference_support), independent of the rung's stepping. Model
tests: no rclpy."""

from __future__ import annotations

import numpy as np
import pytest
from hydraulic_reference_support import RELIEF_BOTH_WAYS, STOPS_BOTH_WAYS, radau_reference

from drs_model import DRSParams
from drs_model import kinematics as kin
from drs_model.fidelity import HydraulicParams
from drs_model.fidelity.scenes import run_scene

P = DRSParams()
S_MIN, S_MAX = kin.stroke_limits(P)
#: Indices of hydraulic_kernels.switching_functions: each chamber at its relief pressure, the rod
#: at the closed and the open stop, each stop's damping reaching zero.
RELIEF_A, RELIEF_B, CLOSED, OPEN, DAMP_CLOSED, DAMP_OPEN = 7, 8, 11, 12, 13, 14
STOPS = [CLOSED, OPEN, DAMP_CLOSED, DAMP_OPEN]


@pytest.fixture(scope="module")
def stops_reference():
    return radau_reference(STOPS_BOTH_WAYS, STOPS)


@pytest.fixture(scope="module")
def relief_reference():
    return radau_reference(RELIEF_BOTH_WAYS, [RELIEF_A, RELIEF_B, *STOPS])


def _errors(trace, ref):
    """The largest differences of stroke [m], force [N] and both pressures [Pa] at every 1 ms."""
    np.testing.assert_allclose(trace.t[1:], ref.t, rtol=0, atol=1e-12)
    return (
        np.max(np.abs(trace.stroke[1:] - ref.stroke)),
        np.max(np.abs(trace.force[1:] - ref.force)),
        np.max(np.abs(trace.pressure_a[1:] - ref.pressure_a)),
        np.max(np.abs(trace.pressure_b[1:] - ref.pressure_b)),
    )


def _on_a_stop(stroke):
    return np.where(stroke > S_MAX, 1, np.where(stroke < S_MIN, -1, 0))


def test_the_reference_crosses_each_stop_both_ways(stops_reference):
    """The scene does what it is for: the reference's rod goes onto and off each stop (the
    crossings located by the event search), and sits on the open stop at 0.15 s and on the
    closed one at 0.3 s, between them at 0.4 s and on the open one again at 0.48 s."""
    ref = stops_reference
    assert len(ref.crossings(OPEN)) >= 2 and len(ref.crossings(DAMP_OPEN)) >= 1
    assert len(ref.crossings(CLOSED)) >= 2 and len(ref.crossings(DAMP_CLOSED)) >= 1
    on = _on_a_stop(ref.stroke)
    at = {t: on[np.argmin(np.abs(ref.t - t))] for t in (0.15, 0.3, 0.4, 0.48)}
    assert at == {0.15: 1, 0.3: -1, 0.4: 0, 0.48: 1}, at


@pytest.mark.parametrize("fraction", [1.0, 0.9, 0.8])
def test_the_stops_contact_is_located_within_the_sub_step(stops_reference, fraction):
    """The default rung (contacts located), at 1.0, 0.9 and 0.8 of the stable sub-step, stays
    within 2 um of stroke, 10 N of force and 0.5 bar of either pressure of the reference
    (measured 0.53-0.68 um, 3.2-4.2 N, 0.14-0.23 bar), whatever where the contact falls in a
    sub-step; its rod is on a stop at the same 1 ms samples as the reference's. Without the
    contact located the same runs are 3.4-6.4 um, 34-62 N, 1.6-2.7 bar off."""
    ref = stops_reference
    located = run_scene("hydraulic", STOPS_BOTH_WAYS, P, stability_fraction=fraction)
    stroke, force, pa, pb = _errors(located, ref)
    assert stroke < 2e-6 and force < 10.0 and max(pa, pb) < 0.5e5, (stroke, force, pa, pb)
    np.testing.assert_array_equal(_on_a_stop(located.stroke[1:]), _on_a_stop(ref.stroke))
    crossing = run_scene(
        "hydraulic", STOPS_BOTH_WAYS, P, stability_fraction=fraction, locate_events=False
    )
    stroke, force, pa, pb = _errors(crossing, ref)
    assert force > 30.0 and max(pa, pb) > 1e5, (stroke, force, pa, pb)


def test_the_relief_is_crossed_both_ways_as_in_the_reference(relief_reference):
    """The piston side crosses the relief's setting upward after the supply rises to 300 bar
    and back down after it returns to 210 bar (each crossing located in the reference, one
    each). The relief's flow is continuous at its setting (only its slope changes), so the
    default rung needs no location there: it stays within 0.2 um, 2 N and 0.1 bar of the
    reference (measured 5e-8 m, 0.26 N, 0.015 bar; with no location at all, 9.5 um and 80 N:
    the rod's contact with the open stop at 47 ms), above the setting at the same 1 ms samples
    as the reference."""
    ref = relief_reference
    up_down = ref.crossings(RELIEF_A)
    assert len(up_down) == 2 and 0.15 < up_down[0] < 0.16 and 0.25 < up_down[1] < 0.26, up_down
    assert ref.crossings(RELIEF_B) == []
    trace = run_scene("hydraulic", RELIEF_BOTH_WAYS, P)
    stroke, force, pa, pb = _errors(trace, ref)
    assert stroke < 2e-7 and force < 2.0 and max(pa, pb) < 1e4, (stroke, force, pa, pb)
    relief = HydraulicParams().relief_pressure
    np.testing.assert_array_equal(trace.pressure_a[1:] > relief, ref.pressure_a > relief)
