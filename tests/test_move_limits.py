"""Moves within the actuator: the inverse-dynamics peak of a commanded path
(:func:`drs_model.inverse.path_peak_force`), the refusal of a move beyond ``force_limit``
(``limit_moves``) and of a segment shorter than the physics step, on every rung."""

from __future__ import annotations

import numpy as np
import pytest

from drs_model import kinematics as kin
from drs_model.errors import ForceLimitError, InputError
from drs_model.fidelity import RUNGS
from drs_model.inverse import inverse_dynamics, path_peak_force, peak_force
from drs_model.profile import quintic_move


def _newton_euler_peak(params, seg, n=4001):
    """|F| peak by Newton-Euler on a dense grid of the segment (the profile's own evaluator)."""
    t = np.linspace(seg.t0, seg.t1, n)
    state = kin.kinematic_state(*seg.evaluate(t), params)
    return float(np.max(np.abs(inverse_dynamics(state, params, "newton-euler").piston_force)))


@pytest.mark.parametrize("duration", [0.002, 0.01, 0.05])
def test_path_peak_matches_newton_euler_on_a_dense_grid(params, duration):
    s_min, s_max = kin.stroke_limits(params)
    seg = quintic_move(params, s_max, duration, s_min)
    peak = path_peak_force(params, [seg.coeffs], [seg.duration])
    dense = _newton_euler_peak(params, seg)
    # 33 samples a segment, refined around the best: within 1e-4 of a 4001-sample grid
    assert abs(peak.force) == pytest.approx(dense, rel=1e-4)
    assert 0.0 <= peak.time <= duration and s_min <= peak.stroke <= s_max


def test_the_seed_opening_peaks_as_the_manoeuvre_does(params):
    """The seed's opening is a quintic of T_opening: its path peak is the manoeuvre's refined
    peak (25.4 kN at 0.904 ms, refined by Brent)."""
    s_min, s_max = kin.stroke_limits(params)
    seg = quintic_move(params, s_max, params.T_opening, s_min)
    ref = peak_force(params)
    got = path_peak_force(params, [seg.coeffs], [seg.duration])
    assert got.force == pytest.approx(ref.force, rel=5e-5)  # the fine grid: 1e-5 s apart
    assert got.time == pytest.approx(ref.time, abs=2e-5)


def test_the_peak_names_its_segment(params):
    s_min, s_max = kin.stroke_limits(params)
    slow = quintic_move(params, s_max, 0.1, s_min)
    fast = quintic_move(params, s_min, 0.004, s_max)
    peak = path_peak_force(params, [slow.coeffs, fast.coeffs], [slow.duration, fast.duration])
    assert peak.segment == 1
    assert abs(peak.force) == pytest.approx(
        abs(path_peak_force(params, [fast.coeffs], [fast.duration]).force), rel=1e-12)


@pytest.mark.parametrize("rung", sorted(RUNGS))
def test_a_2ms_full_stroke_is_refused_with_the_peak_and_the_limit(params, rung):
    sim = RUNGS[rung](params)
    sim.limit_moves = True
    s_max = sim.s_max
    with pytest.raises(ForceLimitError, match=r"force of .* N .* beyond force_limit 20000 N"):
        sim.command_stroke(s_max, 0.002)
    with pytest.raises(ForceLimitError, match="segment 0"):
        sim.command_trajectory([0.002], [s_max])
    assert sim.mode == "hold"  # nothing changed
    sim.command_stroke(s_max, 0.1)  # 0.1 s is within the limit
    assert sim.mode == "stroke"


@pytest.mark.parametrize("rung", sorted(RUNGS))
def test_a_trajectory_segment_beyond_the_limit_is_refused_at_planning(params, rung):
    """The state-independent segments are checked when planned (outside the node's tick)."""
    sim = RUNGS[rung](params)
    sim.limit_moves = True
    s_min, s_max = sim.s_min, sim.s_max
    with pytest.raises(ForceLimitError, match="segment 2"):
        sim.plan_trajectory([0.1, 0.2, 0.202], [s_max, s_min, s_max], [0.0, 0.0, 0.0])
    assert len(sim.plan_trajectory([0.1, 0.2, 0.3], [s_max, s_min, s_max], [0.0, 0.0, 0.0])) == 3


@pytest.mark.parametrize("rung", sorted(RUNGS))
def test_no_segment_is_shorter_than_the_step(params, rung):
    """A 46 mm move in 1 us would pass between two 1 ms steps: refused, limit or not."""
    sim = RUNGS[rung](params)
    with pytest.raises(InputError, match="shorter than the physics step dt = 0.001 s"):
        sim.command_stroke(sim.s_max, 1e-6)
    with pytest.raises(InputError, match="segment 1 .* shorter than the physics step"):
        sim.command_trajectory([0.05, 0.0505], [0.01, 0.02])
    assert sim.mode == "hold"
    sim.command_trajectory([0.05, 0.051], [0.01, 0.0101])  # exactly one step: taken
    assert sim.mode == "stroke"


def test_without_limit_moves_the_seed_manoeuvre_runs(params):
    """Off by default: the seed's own DRS opening needs 25.4 kN, above the 20 kN default."""
    sim = RUNGS["rigid"](params)
    assert sim.limit_moves is False
    sim.command_drs(True)
    sim.limit_moves = True
    sim.reset()
    with pytest.raises(ForceLimitError):
        sim.command_drs(True)


def test_a_plan_made_before_the_limit_is_checked_when_commanded(params):
    sim = RUNGS["rigid"](params)
    plan = sim.plan_trajectory([0.1, 0.2, 0.202], [sim.s_max, sim.s_min, sim.s_max], [0.0] * 3)
    sim.limit_moves = True
    with pytest.raises(ForceLimitError, match="segment 2"):
        sim.command_trajectory(plan)
    assert sim.mode == "hold"
