"""drs_model.kernels: the code generated from the kernels (inlined scalar, numpy) computes what the
kernels compute, and a kernel that breaks the inliner's rules is refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model import kernels
from drs_model.bodies import model_constants
from drs_model.profile import drs_manoeuvre


def _same(a, b) -> bool:
    a, b = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    return bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def test_inlined_scalar_kernels_are_bit_identical(params):
    """SCALAR runs the same operations in the same order: equal to the last bit, NaN where the
    kernel gives NaN (no assembly), over states inside and outside the assembly range."""
    c = model_constants(params)
    k = drs_manoeuvre(params).constants()
    rng = np.random.default_rng(7)
    for b, bd, f, t, s, sd, sdd in rng.uniform(
        [0.2, -150.0, -5e3, -0.01, -0.004, -10.0, -1e4],
        [1.7, 150.0, 3e4, 0.06, 0.05, 10.0, 1e4],
        (3000, 7),
    ):
        assert _same(
            kernels.psi3_acceleration(b, bd, f, c), kernels.SCALAR.psi3_acceleration(b, bd, f, c)
        )
        assert _same(kernels.psi3_configuration(b, c), kernels.SCALAR.psi3_configuration(b, c))
        assert _same(kernels.fused_force(s, sd, sdd, c), kernels.SCALAR.fused_force(s, sd, sdd, c))
        assert _same(kernels.manoeuvre_force(t, c, k), kernels.SCALAR.manoeuvre_force(t, c, k))
    assert math.isnan(kernels.SCALAR.fused_force(-0.01, 0.0, 0.0, c))  # past the dead centre


def test_numpy_kernels_evaluate_arrays_as_the_scalar_ones(params):
    c = model_constants(params)
    s = np.linspace(-0.004, 0.05, 101)
    got = kernels.NUMPY.fused_force(s, 0.3, 50.0, c)
    ref = [kernels.fused_force(float(x), 0.3, 50.0, c) for x in s]
    np.testing.assert_allclose(got, ref, rtol=1e-13, atol=1e-9)
    assert np.isnan(got[0]) and np.isfinite(got[-1])


def test_the_inliner_refuses_an_early_return(monkeypatch):
    def early(x, c):
        if x > 0.0:
            return x
        return -x

    def top(x, c):
        y = early(x, c)
        return y

    monkeypatch.setitem(kernels.__dict__, "early", early)
    monkeypatch.setitem(kernels.__dict__, "top", top)
    monkeypatch.setattr(kernels, "KERNELS", (*kernels.KERNELS, "early", "top"))
    monkeypatch.setattr(kernels, "_callee_source", lambda name: _source(name, early, top))
    with pytest.raises(AssertionError, match="kernel early must end in its only return"):
        kernels._flatten("top")


def _source(name, *fns):
    import ast
    import inspect
    import textwrap

    fn = {f.__name__: f for f in fns}[name]
    return ast.parse(textwrap.dedent(inspect.getsource(fn))).body[0]


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
        held = kernels.SCALAR.manoeuvre_force(0.5 * (a + b), c, k)
        for t in (a, b, a + (b - a) * fractions[2]):
            assert kernels.SCALAR.manoeuvre_force(t, c, k) == held, (name, t)
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
