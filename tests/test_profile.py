"""Quintic segments and the open-hold-close manoeuvre against the seed and the boundary rules."""

from __future__ import annotations

import importlib.util
import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from trajectory_support import scalar_segments

from drs_model.errors import InputError, StrokeRangeError
from drs_model.kinematics import stroke_limits
from drs_model.profile import QuinticSegment, drs_manoeuvre, quintic_coefficients, quintic_move

SEED_S_MIN, SEED_S_MAX = 0.000198939129915359, 0.0460748980054946
# seed (2.6.3) and (2.6.7), absolute-time coefficients a0..a5
SEED_OPENING = [0.0001989391299, 0.0, 0.0, 458759.5888, -6.881393831e7, 2.752557533e9]
SEED_CLOSING = [
    487.4322620,
    -55051.15065,
    2.477301779e6,
    -5.550991024e7,
    6.193254448e8,
    -2.752557533e9,
]


def test_coefficients_match_the_seed_when_built_on_its_limits(params):
    m = drs_manoeuvre(params, SEED_S_MIN, SEED_S_MAX)
    # the seed prints 10 significant digits
    np.testing.assert_allclose(m.opening.absolute_coefficients(), SEED_OPENING, rtol=5e-10, atol=0)
    np.testing.assert_allclose(m.closing.absolute_coefficients(), SEED_CLOSING, rtol=5e-10)


def _poly_derivs(coeffs, tau):
    c = np.polynomial.Polynomial(coeffs)
    return c(tau), c.deriv(1)(tau), c.deriv(2)(tau)


@given(
    st.floats(1e-3, 1.0),
    st.floats(-0.1, 0.1),
    st.floats(-0.1, 0.1),
    st.floats(-5, 5),
    st.floats(-5, 5),
    st.floats(-100, 100),
    st.floats(-100, 100),
)
@settings(max_examples=80, deadline=None)
def test_quintic_meets_its_six_conditions(T, s0, s1, v0, v1, a0, a1):
    c = quintic_coefficients(T, s0, s1, v0, v1, a0, a1)
    start, end = _poly_derivs(c, 0.0), _poly_derivs(c, T)
    scale = 1 + abs(s0) + abs(s1) + abs(v0) * T + abs(v1) * T + (abs(a0) + abs(a1)) * T * T
    np.testing.assert_allclose(start, (s0, v0, a0), atol=1e-9 * scale / min(T, 1) ** 2)
    np.testing.assert_allclose(end, (s1, v1, a1), atol=1e-9 * scale / min(T, 1) ** 2)


def test_manoeuvre_shape(params):
    m = drs_manoeuvre(params)
    s_min, s_max = stroke_limits(params)
    t = np.array([-1.0, 0.0, 0.005, 0.01, 0.025, 0.04, 0.045, 0.05, 1.0])
    s, v, a = m.evaluate(t)
    np.testing.assert_allclose(s[[0, 1, 7, 8]], s_min, atol=1e-15)
    np.testing.assert_allclose(s[[3, 4, 5]], s_max, atol=1e-15)
    assert s[2] == pytest.approx(0.5 * (s_min + s_max), abs=1e-15)  # symmetric quintic
    assert s[6] == pytest.approx(0.5 * (s_min + s_max), abs=1e-15)
    # peak speed of a rest-to-rest quintic: 15/8 h/T
    assert v[2] == pytest.approx(15 / 8 * (s_max - s_min) / params.T_opening, rel=1e-12)
    assert v[6] == pytest.approx(-v[2], rel=1e-12)
    np.testing.assert_array_equal(v[[0, 4, 8]], 0.0)
    np.testing.assert_array_equal(a[[0, 4, 8]], 0.0)


def test_rates_against_finite_differences(params):
    m = drs_manoeuvre(params)
    t = np.linspace(0.0, params.T_total, 401)[1:-1]
    h = 1e-8
    s, v, a = m.evaluate(t)
    sp, vp, _ = m.evaluate(t + h)
    sm, vm, _ = m.evaluate(t - h)
    np.testing.assert_allclose(v, (sp - sm) / (2 * h), atol=1e-5)
    np.testing.assert_allclose(a, (vp - vm) / (2 * h), atol=1e-2 * np.abs(a).max() * 1e-3 + 1e-3)


def test_continuity_at_the_joints(params):
    m = drs_manoeuvre(params)
    eps = 1e-12
    for tk in m.kinks:
        before = np.array(m.evaluate(tk - eps))
        after = np.array(m.evaluate(tk + eps))
        # s, s', s'' continuous; tolerances = what 2e-12 s of motion can change them by
        assert abs(before[0] - after[0]) < 1e-15
        assert abs(before[1] - after[1]) < 1e-8
        assert abs(before[2] - after[2]) < 1e-2


def test_quintic_move_from_a_moving_state(params):
    s_min, s_max = stroke_limits(params)
    seg = quintic_move(params, s_target=0.03, duration=0.02, s0=0.01, v0=1.5, a0=-20.0, t0=1.0)
    s, v, a = seg.evaluate(np.array([1.0, 1.02, 2.0]))
    np.testing.assert_allclose([s[0], v[0], a[0]], [0.01, 1.5, -20.0], atol=1e-9)
    np.testing.assert_allclose([s[1], v[1], a[1]], [0.03, 0.0, 0.0], atol=1e-9)
    assert s[2] == pytest.approx(0.03, abs=1e-15)
    assert v[2] == pytest.approx(0.0, abs=1e-12) and a[2] == pytest.approx(0.0, abs=1e-9)
    assert isinstance(seg, QuinticSegment) and seg.t1 == pytest.approx(1.02)
    assert s_min < 0.03 < s_max


def test_bad_moves(params):
    s_min, s_max = stroke_limits(params)
    with pytest.raises(StrokeRangeError, match=r"target stroke 0\.1 m is outside \[s_min, s_max\]"):
        quintic_move(params, 0.1, 0.01, s0=0.01)
    with pytest.raises(StrokeRangeError, match=r"target stroke -0\.001 m is outside"):
        quintic_move(params, -0.001, 0.01, s0=0.01)
    with pytest.raises(InputError, match=r"duration must be a finite number > 0 s, got 0\.0"):
        quintic_move(params, 0.02, 0.0, s0=0.01)
    with pytest.raises(InputError, match=r"duration must be a finite number > 0 s, got -1"):
        quintic_coefficients(-1, 0.0, 1.0)
    with pytest.raises(InputError, match=r"s_target must be finite, got nan"):
        quintic_move(params, math.nan, 0.01, s0=0.01)
    with pytest.raises(InputError, match=r"time must be finite"):
        drs_manoeuvre(params).evaluate(np.array([0.0, math.inf]))
    # the limits themselves are accepted
    quintic_move(params, s_max, 0.01, s0=s_min)


# ---- trajectory plans: all segments at once, the state-dependent ones apart --------------------
@given(
    n=st.integers(1, 40),
    seed=st.integers(0, 2**31),
    with_rates=st.booleans(),
    start=st.floats(0.0, 1.0),
)
@settings(max_examples=60, deadline=None)
def test_a_plan_builds_the_segments_of_the_boundary_conditions(params, n, seed, with_rates, start):
    """Vectorised over all segments, the plan + head give the coefficients of the segment-by-
    segment closed form (quintic_coefficients) to 1e-9 relative, and each segment meets its
    points' stroke and rate (to 1e-12 m, 1e-9 m/s)."""
    from drs_model.profile import QuinticPath, plan_trajectory

    s_min, s_max = stroke_limits(params)
    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.005, 0.05, n))
    strokes = rng.uniform(s_min + 0.1 * (s_max - s_min), s_max - 0.1 * (s_max - s_min), n)
    rates = None
    if with_rates:
        rates = rng.uniform(-0.3, 0.3, n)
        rates[-1] = 0.0
    s0 = s_min + start * (s_max - s_min)
    try:
        plan = plan_trajectory(params, times, strokes, rates)
        path = QuinticPath.of_plan(plan, 0.0, plan.head(s0, 0.0, 0.0))
    except StrokeRangeError:
        return  # an overshooting path (checked against the actuator's refusals elsewhere)
    ref = scalar_segments(times, strokes, rates, s0)
    assert len(path) == n and plan.n_head == (1 if with_rates or n == 1 else 2)
    for seg, want in zip(path, ref, strict=True):
        assert seg.t0 == pytest.approx(want.t0, abs=1e-15)
        assert seg.duration == pytest.approx(want.duration, rel=1e-15)
        scale = np.abs(want.coeffs) + 1e-300
        np.testing.assert_array_less(
            np.abs(np.subtract(seg.coeffs, want.coeffs)), 1e-9 * scale + 1e-15
        )
    for k in range(n):
        s, v, a = path.at(float(times[k]))
        assert s == pytest.approx(strokes[k], abs=1e-12)
        if rates is not None:
            assert v == pytest.approx(rates[k], abs=1e-9)


def test_segment_lookup_by_bisection_matches_a_scan(params):
    """The segment in force at a time is the first ending at or after it (within 1e-12 s):
    bisection over 10,000 segments agrees with a linear scan, at the joints too."""
    from drs_model.profile import QuinticPath, plan_trajectory

    s_min, s_max = stroke_limits(params)
    n = 10_000
    times = 1e-3 * np.arange(1, n + 1)
    strokes = 0.5 * (s_min + s_max) + 0.01 * np.sin(times * 20)
    plan = plan_trajectory(params, times, strokes)
    path = QuinticPath.of_plan(plan, 2.0, plan.head(0.03, 0.0, 0.0))
    ends = [path.t_start + e for e in plan.times]
    rng = np.random.default_rng(1)
    probes = np.concatenate(
        [rng.uniform(1.9, 12.1, 300), np.array(ends[:50]) + 1e-13, np.array(ends[:50]) - 1e-9]
    )
    for t in probes:
        scan = next((k for k, e in enumerate(ends) if t - path.t_start <= plan.ends[k]), n - 1)
        assert path.segment_index(float(t)) == scan
        if path.t_start <= t <= path.t_end:
            assert path[scan].t0 - 1e-12 <= t <= path[scan].t1 + 1e-12
    assert path[-1].t1 == pytest.approx(path.t_end, abs=1e-12)


@pytest.mark.parametrize(
    ("times", "strokes", "rates", "error", "match"),
    [
        ([0.01, 0.01], [0.02, 0.03], None, InputError, r"times must increase strictly from > 0 s"),
        ([0.0], [0.02], None, InputError, r"times must increase strictly from > 0 s"),
        ([0.01], [0.2], None, StrokeRangeError, r"stroke 0\.2 m is outside \[s_min, s_max\]"),
        ([0.01], [math.nan], None, InputError, r"must be finite"),
        ([], [], None, InputError, r"needs 1\.\.10000 points"),
        (
            np.arange(1, 10_002) * 1e-3,
            np.full(10_001, 0.02),
            None,
            InputError,
            r"needs 1\.\.10000 points with one stroke per time, got 10001 times",
        ),
        ([0.01], [0.02], [math.inf], InputError, r"rates must be 1 finite values"),
        ([0.01, 0.02], [0.02, 0.03], [0.1, 0.2], InputError, r"must end at rest"),
        # a later segment that overshoots is refused by the plan alone (no state needed)
        (
            [0.01, 0.02, 0.03],
            [0.02, 0.045, 0.046],
            [0.0, 2.0, 0.0],
            StrokeRangeError,
            r"leaves \[s_min, s_max\].* on its way to point 2 \(of 0\.\.2\)",
        ),
    ],
)
def test_a_plan_refuses_what_the_actuator_refuses(params, times, strokes, rates, error, match):
    from drs_model.profile import plan_trajectory

    with pytest.raises(error, match=match):
        plan_trajectory(params, times, strokes, rates)


@given(
    coeffs=st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    duration=st.floats(1e-3, 0.5),
    width=st.floats(0.01, 2.0),
)
@settings(max_examples=200, deadline=None)
def test_a_path_whose_hull_stays_inside_is_sampled_inside(coeffs, duration, width):
    """hull_leaves is a safe short cut for path_extremes: where the control points stay inside
    the limits, every sampled instant (and a dense sampling) lies inside too."""
    from drs_model.path_range import hull_leaves, path_extremes

    c = np.array(coeffs)
    tau = np.linspace(0.0, duration, 2001)
    path = np.polynomial.polynomial.polyval(tau, c)
    centre = 0.5 * (path.min() + path.max())
    for limits in ((centre - width, centre + width), (path.min(), path.max())):
        if not hull_leaves(c, duration, limits)[0]:
            lo, hi = path_extremes(c, duration)
            assert limits[0] - 1e-12 <= lo[0] and hi[0] <= limits[1] + 1e-12
            assert limits[0] - 1e-12 <= path.min() and path.max() <= limits[1] + 1e-12


@pytest.mark.skipif(
    importlib.util.find_spec("numba") is None and not os.environ.get("CI"),
    reason="numba is not installed (pip install drs[fast]): nothing is compiled to compare",
)
@given(
    coeffs=st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    duration=st.floats(1e-3, 0.5),
    lo=st.floats(-2.0, 0.0),
    width=st.floats(0.0, 3.0),
)
@settings(max_examples=200, deadline=None)
def test_the_compiled_hull_check_is_its_plain_source(coeffs, duration, lo, width):
    """The hull check runs compiled (numba) in the node; its plain source gives the same
    answer, and a control point is outside exactly where the numpy basis change puts it."""
    from drs_model import path_range

    c = np.array([coeffs], dtype=float)
    d = np.array([duration])
    limits = (lo, lo + width)
    plain, compiled = np.empty(1, dtype=bool), np.empty(1, dtype=bool)
    m = path_range._TO_BERNSTEIN
    n_plain = path_range.bernstein_hull(c, d, m, *limits, plain)
    n_compiled = path_range._hull()(c, d, m, *limits, compiled)
    assert (n_plain, bool(plain[0])) == (n_compiled, bool(compiled[0]))
    # the control points by numpy: coefficients in u = tau / T, to the Bernstein basis
    bern = (c[0] * duration ** np.arange(6)) @ m.T
    margin = 1e-12 * max(1.0, np.abs(bern).max())
    if bern.min() < limits[0] - margin or bern.max() > limits[1] + margin:
        assert plain[0]
    elif bern.min() > limits[0] + margin and bern.max() < limits[1] - margin:
        assert not plain[0]


@given(
    start=st.floats(0.0, 1.0),
    v0=st.floats(-40.0, 40.0),
    a0=st.floats(-2e4, 2e4),
    target=st.floats(0.0, 1.0),
    duration=st.sampled_from([None, 0.002, 0.01, 0.05]),
)
@settings(max_examples=150, deadline=None)
def test_a_move_is_refused_exactly_when_its_samples_leave_the_range(
    params, start, v0, a0, target, duration
):
    """StrokeMotion.command_stroke (the hull first, the samples only when it leaves) refuses a
    move exactly when the move's sampled path leaves [s_min, s_max], computed independently
    from the same segment; from moving states that overshoot and from rest."""
    from drs_model.motion import StrokeMotion
    from drs_model.path_range import PATH_SAMPLES

    lo, hi = stroke_limits(params)
    s0, s1 = lo + start * (hi - lo), lo + target * (hi - lo)
    motion = StrokeMotion(params, 1e-3)
    dur = (
        duration if duration is not None else max(params.T_opening * abs(s1 - s0) / (hi - lo), 2e-3)
    )
    seg = quintic_move(params, s1, dur, s0, v0, a0, limits=(lo, hi))
    tau = np.linspace(0.0, seg.duration, PATH_SAMPLES)
    path = np.polynomial.polynomial.polyval(tau, seg.coeffs)
    leaves = path.min() < lo - 1e-12 or path.max() > hi + 1e-12
    try:
        motion.command_stroke(s1, duration, start=(s0, v0, a0))
        refused = False
    except StrokeRangeError:
        refused = True
    assert refused == leaves, (path.min() - lo, hi - path.max())


@given(
    t0=st.floats(0.0, 100.0),
    duration=st.floats(1e-4, 1.0),
    s0=st.floats(0.0, 0.05),
    s1=st.floats(0.0, 0.05),
    v0=st.floats(-5.0, 5.0),
    a0=st.floats(-1e4, 1e4),
)
def test_a_segments_end_stroke_is_where_its_evaluation_ends(t0, duration, s0, s1, v0, a0):
    """``end_stroke`` (the scalar kernel at the local end) against the array evaluation at and
    after ``t1`` (the same quintic by numpy), and against the target of a move to rest."""
    from drs_model.profile import QuinticSegment

    seg = QuinticSegment.between(t0, duration, s0, s1, v0, 0.0, a0, 0.0)
    tol = 1e-12 * (1.0 + abs(s1) + abs(v0) * duration + abs(a0) * duration**2)
    assert abs(seg.end_stroke - float(seg.evaluate(seg.t1 + 1.0)[0])) <= tol
    assert abs(seg.end_stroke - s1) <= tol


@given(
    coeffs=st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    duration=st.floats(1e-3, 0.5),
    margin=st.sampled_from([-1e-9, -1e-12, -1e-13, 0.0, 1e-13, 1e-12, 1e-9]),
)
@settings(max_examples=300, deadline=None)
def test_leaving_paths_says_what_sampling_says(coeffs, duration, margin):
    """The hull only spares the sampling: ``leaving_paths`` names a segment exactly when its
    samples leave the limits by more than PATH_TOL (the reference: the samples themselves),
    with limits at the samples' own extremes give or take ``margin``."""
    from drs_model.path_range import PATH_TOL, leaving_paths, path_extremes

    c = np.array(coeffs)
    lo, hi = (float(x[0]) for x in path_extremes(c, duration))
    limits = (lo - margin, hi + margin)
    sampled = lo < limits[0] - PATH_TOL or hi > limits[1] + PATH_TOL
    assert bool(leaving_paths(c, duration, limits)[0].size) == sampled


def test_a_path_beyond_the_tolerance_by_a_rounding_error_is_still_sampled_and_named():
    """The hull's margin is half the samples' tolerance: a path whose highest sample lies an
    ulp beyond ``limits + PATH_TOL`` (a case a review found) is sampled and named, as the
    samples say (the reference: the samples themselves)."""
    from drs_model.path_range import PATH_TOL, leaving_paths, path_extremes

    c = np.array(
        [0.4376478481316062, 0.7576256005109634, 0.4282589672224051]
        + [0.842197335167749, -0.21007319199851215, 0.6018175419704566]
    )
    duration, limits = 0.22286590696932956, (-0.5623521518683938, 0.6369034486996445)
    hi = float(path_extremes(c, duration)[1][0])
    assert 0.0 < hi - (limits[1] + PATH_TOL) < 1e-15
    assert leaving_paths(c, duration, limits)[0].tolist() == [0]


def test_a_move_to_a_stop_from_rest_is_decided_without_sampling(params, monkeypatch):
    """A move ends on the stop exactly, its last control point a rounding error beyond: the
    hull, widened by the samples' tolerance, decides it (no sampling on the node's tick)."""
    from drs_model import path_range
    from drs_model.actuator import ActuatorSim

    calls = []
    original = path_range.path_extremes
    monkeypatch.setattr(
        path_range, "path_extremes", lambda *a, **k: calls.append(1) or original(*a, **k)
    )
    sim = ActuatorSim(params, dt=1e-3)
    for open_flap in (True, False, True):
        sim.command_drs(open_flap)
        for _ in range(40):
            sim.step()  # to rest on the stop
    assert calls == []
