"""drs_model.kernels and drs_model.elementwise: the kernels on arrays compute what the plain
kernels compute, the manoeuvre rests exactly outside its moves, profile_held says where, and
the kernels' arctangent is libm's within 1 ulp."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model import elementwise, kernels
from drs_model.bodies import model_constants
from drs_model.profile import drs_manoeuvre


def _same(a, b) -> bool:
    a, b = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    return bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def test_elementwise_kernels_evaluate_arrays_as_the_scalar_ones(params):
    """The array path (numba gufuncs, or numpy.vectorize without numba) gives the plain kernel's
    values, NaN where the kernel gives NaN (past the dead centre), for any shape."""
    c = model_constants(params)
    s = np.linspace(-0.004, 0.05, 101)
    got = elementwise.fused_force(s, 0.3, 50.0, c)
    ref = [kernels.fused_force(float(x), 0.3, 50.0, c) for x in s]
    np.testing.assert_allclose(got, ref, rtol=1e-13, atol=1e-9)
    assert np.isnan(got[0]) and np.isfinite(got[-1])
    k = drs_manoeuvre(params).constants()
    t = np.linspace(-0.01, 0.06, 12).reshape(3, 4)
    s, sd, sdd = elementwise.manoeuvre_profile(t, k)
    assert s.shape == (3, 4)
    ref = np.array([kernels.manoeuvre_profile(float(x), k) for x in t.ravel()]).T.reshape(3, 3, 4)
    np.testing.assert_allclose(np.stack([s, sd, sdd]), ref, rtol=1e-13, atol=1e-15)


def test_the_profile_rests_exactly_outside_the_moves(params):
    """Before the opening, in the hold and after the closing (joints included) the kernel gives
    s_min or s_max exactly and no motion; inside a move, the quintic."""
    man = drs_manoeuvre(params)
    k = man.constants()
    for t, s in (
        (-1.0, man.s_min),
        (0.0, man.s_min),
        (0.01, man.s_max),
        (0.025, man.s_max),
        (0.04, man.s_max),
        (0.05, man.s_min),
        (1.0, man.s_min),
    ):
        assert kernels.manoeuvre_profile(t, k) == (s, 0.0, 0.0), t
    s, sd, _ = kernels.manoeuvre_profile(0.005, k)
    assert s == pytest.approx(0.5 * (man.s_min + man.s_max), rel=1e-12) and sd > 0.0


@settings(max_examples=200, deadline=None)
@given(
    t0_open=st.floats(-0.02, 0.02),
    fractions=st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(0.0, 1.0)),
)
def test_a_held_profile_is_one_value_to_the_bit(params, t0_open, fractions):
    """Where profile_held says the manoeuvre holds still over [a, b], the kernel force at any t
    in it equals the force at the middle bit for bit (the compiled path and ManoeuvreForce then
    evaluate it once per segment); where the rod moves somewhere in [a, b] it says no."""
    c = model_constants(params)
    k = list(drs_manoeuvre(params).constants())
    k[0] += t0_open  # shift the whole manoeuvre: t0 - k[0] is then rounded differently
    k[8] += t0_open
    opening_end, closing_start, closing_end = k[0] + k[1], k[8], k[8] + k[9]
    spans = {
        "before": (k[0] - 0.01, k[0]),
        "hold": (opening_end, closing_start),
        "after": (closing_end, closing_end + 0.01),
    }
    for name, (lo, hi) in spans.items():
        lo, hi = lo + 1e-9, hi - 1e-9  # clear of the joints, whose sums round either way
        a = lo + (hi - lo) * min(fractions[:2])
        b = lo + (hi - lo) * max(fractions[:2])
        assert kernels.profile_held(a, b, k), (name, a, b)
        held = kernels.fused_manoeuvre_force(0.5 * (a + b), c, k)
        for t in (a, b, a + (b - a) * fractions[2]):
            assert kernels.fused_manoeuvre_force(t, c, k) == held, (name, t)
    # any span that reaches into the opening or the closing moves
    assert not kernels.profile_held(k[0] - 1e-3, k[0] + 1e-6, k)
    assert not kernels.profile_held(opening_end - 1e-6, closing_start, k)
    assert not kernels.profile_held(opening_end, closing_start + 1e-6, k)
    assert not kernels.profile_held(closing_end - 1e-6, closing_end + 1e-3, k)


def test_the_seed_hold_is_held_from_joint_to_joint(params):
    """The seed's hold segment, exactly between its breakpoints (10 and 40 ms), is held: the
    compiled path evaluates its force once."""
    k = drs_manoeuvre(params).constants()
    kinks = drs_manoeuvre(params).kinks
    assert kernels.profile_held(kinks[1], kinks[2], k)
    assert not kernels.profile_held(kinks[0], kinks[1], k)
    assert not kernels.profile_held(kinks[2], kinks[3], k)


_SPECIAL = (0.0, -0.0, 1e-310, -1e-310, 1.0, -1.0, math.inf, -math.inf, math.nan, 1e308, -1e308)


@settings(max_examples=3000, deadline=None)
@given(
    st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from(_SPECIAL),
    st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from(_SPECIAL),
)
def test_arctangent_is_math_atan2_within_one_ulp(y, x):
    """The kernels' arctangent against libm's: within 1 ulp of ``math.atan2`` for every pair of
    floats (both signs of zero, subnormals, infinities, NaN; any quadrant), the same NaN and the
    same signed zero, and always in [-pi, pi]."""
    got, ref = kernels.arctangent(y, x), math.atan2(y, x)
    if math.isnan(ref):
        assert math.isnan(got)
        return
    assert abs(got - ref) <= math.ulp(ref), (y, x, got, ref)
    assert math.copysign(1.0, got) == math.copysign(1.0, ref), (y, x, got, ref)
    assert -math.pi <= got <= math.pi


def test_arctangent_over_the_flap_half_plane_is_within_one_ulp():
    """Where the fused force calls it (``x > 0``: the flap's angle from its sine and cosine),
    300,000 points of every size of ``y / x``: within 1 ulp of ``math.atan2``, most of them
    equal."""
    rng = np.random.default_rng(11)
    y = rng.normal(size=300_000) * 10.0 ** rng.uniform(-8, 8, 300_000)
    x = np.abs(rng.normal(size=300_000)) + 1e-12
    got = np.array([kernels.arctangent(a, b) for a, b in zip(y.tolist(), x.tolist(), strict=True)])
    ref = np.arctan2(y, x)  # numpy's own arctan2 (libm's), an independent reader of the pairs
    ulps = np.abs(got - ref) / np.spacing(np.abs(ref))
    assert ulps.max() <= 1.0
    assert np.mean(got == ref) > 0.8  # 0.87 here: rounded as libm rounds, not biased
