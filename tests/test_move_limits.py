"""Moves within the actuator: the inverse-dynamics peak of a commanded path
(:func:`drs_model.inverse.path_peak_force`), the refusal of a move beyond ``force_limit``
(``limit_moves``) and of a segment shorter than the physics step, on every rung."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from drs_model import kinematics as kin
from drs_model.errors import ForceLimitError, InputError
from drs_model.fidelity import RUNGS
from drs_model.inverse import inverse_dynamics, path_peak_force, peak_force
from drs_model.params import FORCE_LIMIT_DEFAULT_N
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
        abs(path_peak_force(params, [fast.coeffs], [fast.duration]).force), rel=1e-12
    )


@pytest.mark.parametrize("rung", sorted(RUNGS))
def test_a_2ms_full_stroke_is_refused_with_the_peak_and_the_limit(params, rung):
    sim = RUNGS[rung](params)  # limit_moves by default
    s_max = sim.s_max
    with pytest.raises(ForceLimitError, match=r"force of .* N .* beyond force_limit 30000 N"):
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


@pytest.mark.parametrize("rung", sorted(RUNGS))
def test_the_seed_manoeuvre_fits_the_default_limit(params, rung):
    """On by default: the seed's own opening and closing (25.4 kN, 10 ms each) fit the 30 kN
    default at the seed's times; under a limit below their peak they take longer, their peak
    within it; without limit_moves they keep the seed's times."""
    sim = RUNGS[rung](params)
    assert sim.limit_moves is True and sim.force_limit == FORCE_LIMIT_DEFAULT_N == 3.0e4
    assert sim.command_drs(True).duration == params.T_opening
    sim.advance(round(params.T_opening / sim.dt) + 1)
    assert sim.command_drs(False).duration == params.T_closing
    limit = 0.9 * abs(peak_force(params).force)
    seg = RUNGS[rung](params, force_limit=limit).command_drs(True)
    assert seg.duration > params.T_opening
    peak = _finite_difference_peak(params, seg.evaluate(seg.t0)[0], sim.s_max, seg.duration)
    assert 0.98 * limit <= peak <= 1.001 * limit
    free = RUNGS[rung](params, force_limit=limit, limit_moves=False).command_drs(True)
    assert free.duration == params.T_opening


def test_a_plan_made_before_the_limit_is_checked_when_commanded(params):
    sim = RUNGS["rigid"](params, limit_moves=False)
    plan = sim.plan_trajectory([0.1, 0.2, 0.202], [sim.s_max, sim.s_min, sim.s_max], [0.0] * 3)
    sim.limit_moves = True
    with pytest.raises(ForceLimitError, match="segment 2"):
        sim.command_trajectory(plan)
    assert sim.mode == "hold"


def _finite_difference_peak(params, s0, s1, duration, n=4001):
    """|F| peak of a rest-to-rest minimum-jerk move written here (``s0 + (s1 - s0)(10u^3 -
    15u^4 + 6u^5)``, positions only), its rate and acceleration by finite differences of those
    positions (``numpy.gradient``, second order), the force by Newton-Euler."""
    t = np.linspace(0.0, duration, n)
    u = t / duration
    s = s0 + (s1 - s0) * u**3 * (10.0 - 15.0 * u + 6.0 * u**2)
    sd = np.gradient(s, t, edge_order=2)
    sdd = np.gradient(sd, t, edge_order=2)
    state = kin.kinematic_state(s, sd, sdd, params)
    return float(np.max(np.abs(inverse_dynamics(state, params, "newton-euler").piston_force)))


@settings(max_examples=40, deadline=None)
@given(
    start=st.floats(0.0, 1.0),
    end=st.floats(0.0, 1.0),
    duration=st.floats(1e-3, 0.05),
    ratio=st.floats(0.5, 2.0),
)
def test_a_move_is_refused_exactly_when_its_peak_exceeds_the_limit(
    params, start, end, duration, ratio
):
    """Over strokes, durations and limits (``ratio`` times the independent peak): a stroke
    command from rest is refused when the independent peak exceeds force_limit, taken when it
    is below (a band of 0.2 % either side left out: the finite differences and the grid), and
    a refusal names that peak and the limit."""
    s_min, s_max = kin.stroke_limits(params)
    s0, s1 = s_min + start * (s_max - s_min), s_min + end * (s_max - s_min)
    assume(abs(s1 - s0) > 1e-6 and abs(ratio - 1.0) > 2e-3)
    peak = _finite_difference_peak(params, s0, s1, duration)
    limit = ratio * peak
    sim = RUNGS["rigid"](params, force_limit=limit)
    sim.reset(s=s0)
    if peak < limit:
        sim.command_stroke(s1, duration)
        assert sim.mode == "stroke"
        return
    with pytest.raises(ForceLimitError) as refused:
        sim.command_stroke(s1, duration)
    named = float(re.search(r"piston force of (\S+) N", str(refused.value)).group(1))
    assert abs(named) == pytest.approx(peak, rel=1e-3)
    assert f"beyond force_limit {limit:g} N" in str(refused.value)
    assert sim.mode == "hold"


@settings(max_examples=30, deadline=None)
@given(start=st.floats(0.0, 1.0), end=st.floats(0.0, 1.0), rung=st.sampled_from(sorted(RUNGS)))
def test_a_stroke_command_given_no_duration_takes_one_within_the_limit(params, start, end, rung):
    """``~/stroke_cmd`` gives no duration: the move takes the seed's (T_opening scaled by the
    distance) where that fits force_limit, else the shortest that fits, within 2 %: its
    independent peak lies in [0.98, 1.001] x force_limit."""
    sim = RUNGS[rung](params)
    s_min, s_max = sim.s_min, sim.s_max
    s0, s1 = s_min + start * (s_max - s_min), s_min + end * (s_max - s_min)
    assume(abs(s1 - s0) > 1e-6)
    sim.reset(s=s0)
    seed = max(params.T_opening * abs(s1 - s0) / (s_max - s_min), 2 * sim.dt)
    told = sim.stroke_duration(s1)
    seg = sim.command_stroke(s1)
    assert seg.duration == told
    assert seg.duration == pytest.approx(max(seg.duration, seed), rel=1e-12)  # never shorter
    peak = _finite_difference_peak(params, s0, s1, seg.duration)
    assert peak <= 1.001 * sim.force_limit
    if seg.duration > seed * (1.0 + 1e-9):  # stretched
        assert peak >= 0.98 * sim.force_limit
    else:
        assert _finite_difference_peak(params, s0, s1, seed) <= 1.001 * sim.force_limit


def test_a_short_move_off_the_closed_stop_is_stretched_not_refused(params):
    """20 mm off the closed stop in the seed's 4.4 ms needs 68 kN; given no duration it takes
    longer, given that duration it is refused, and without limit_moves it runs as the seed's."""
    sim = RUNGS["rigid"](params)
    seed = params.T_opening * 0.02 / (sim.s_max - sim.s_min)
    with pytest.raises(ForceLimitError, match="beyond force_limit 30000 N"):
        sim.command_stroke(sim.s_min + 0.02, seed)
    seg = sim.command_stroke(sim.s_min + 0.02)
    assert seg.duration > 1.3 * seed
    free = RUNGS["rigid"](params, limit_moves=False).command_stroke(sim.s_min + 0.02)
    assert free.duration == pytest.approx(seed, rel=1e-12)


def test_a_path_checked_again_is_not_evaluated_again_and_acts_the_same(params, monkeypatch):
    """The actuator keeps its last peak: a stroke command's stretched segment is checked once,
    and commands repeated at rest (a node's client at 100 Hz) cost no evaluation; the motion is
    bit for bit that of an actuator that evaluates every time."""
    import drs_model.inverse as inverse
    from drs_model.actuator import ActuatorSim

    calls = []
    original = inverse.path_peak_force

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    s_min, s_max = kin.stroke_limits(params)
    targets = [s_min + 0.2 * (s_max - s_min)] * 5 + [s_min + 0.7 * (s_max - s_min)] * 5

    def run(fresh_every_time: bool):
        sim = ActuatorSim(params, dt=1e-3)
        out = []
        for target in targets:
            if fresh_every_time:
                sim._peaks.clear()
            sim.command_stroke(target)
            for _ in range(20):
                sim.step()
            out.append((sim.state.t, *sim.state.q, *sim.state.qd, sim.state.piston_force))
        return np.array(out)

    monkeypatch.setattr(inverse, "path_peak_force", counted)
    kept = run(False)
    kept_calls = len(calls)
    calls.clear()
    every = run(True)
    # once per distinct segment (the moves, and each target first held at rest), not twice a
    # command
    assert 2 * kept_calls <= len(calls), (kept_calls, len(calls))
    np.testing.assert_array_equal(kept, every)


def test_a_drs_move_asked_ahead_is_not_evaluated_again(params, monkeypatch):
    """``drs_duration`` (what the node asks before its lock) keeps the move's peak: the
    ``command_drs`` that follows from the same state evaluates none, and takes that duration."""
    import drs_model.inverse as inverse
    from drs_model.actuator import ActuatorSim

    calls = []
    original = inverse.path_peak_force

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(inverse, "path_peak_force", counted)
    for open_flap in (True, False):
        sim = ActuatorSim(params, dt=1e-3)
        if not open_flap:  # closing from the open stop, at rest
            sim.command_drs(True)
            for _ in range(60):
                sim.step()
        duration = sim.drs_duration(open_flap)
        before = len(calls)
        seg = sim.command_drs(open_flap)
        assert len(calls) == before
        assert seg.duration == duration


def test_a_drs_duration_asked_ahead_is_not_reused_from_another_state(params):
    """The duration kept for the command that follows is the one of the same state: asked at
    rest, then the flap moves, the answer is that of an actuator never asked ahead (the
    reference: the same commands and steps); and under another rule (limit_moves off) the
    seed's time, not the stretched one kept."""
    from drs_model.actuator import ActuatorSim

    asked, fresh = ActuatorSim(params, dt=1e-3), ActuatorSim(params, dt=1e-3)
    asked.drs_duration(False)  # kept: closing from rest at the closed stop
    for sim in (asked, fresh):
        sim.command_drs(True)
        for _ in range(5):
            sim.step()
    assert asked.drs_duration(False) == fresh.drs_duration(False)  # closing mid-opening

    weak = ActuatorSim(params, dt=1e-3, force_limit=20_000.0)  # the seed's 10 ms needs 25.4 kN
    stretched = weak.drs_duration(True)
    assert stretched > params.T_opening
    weak.limit_moves = False
    assert weak.drs_duration(True) == params.T_opening
