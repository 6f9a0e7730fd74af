"""The adaptive driver (segments, output, projection, statistics) and the fixed-step integrator
(order, refusals, agreement with solve_ivp)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drs_model import forward as fw
from drs_model import kinematics as kin
from drs_model.errors import (
    DRSError,
    InputError,
    IntegrationError,
    SingularConfigurationError,
    StrokeRangeError,
)
from drs_model.forward import (
    FIXED_STEP_METHODS,
    SCIPY_METHODS,
    FixedStepIntegrator,
    simulate,
)

S0 = 0.02  # mid-stroke start [m]
F_CONST = 500.0  # N: lifts the flap from S0 by ~3 mm in 10 ms


@pytest.fixture(scope="module")
def mforce(params):
    return fw.ManoeuvreForce(params)


def _reference(params, t_eval, force=F_CONST, s0=S0):
    q0 = kin.solve_position(s0, params)
    return simulate(
        "psi3",
        force,
        (0.0, t_eval[-1]),
        params=params,
        rtol=1e-13,
        initial=(q0, np.zeros(3)),
        t_eval=t_eval,
    )


# ---- adaptive driver --------------------------------------------------------------------------
def test_t_eval_is_honoured_across_segments(params, mforce):
    t = np.array([0.0, 0.005, 0.01, 0.02, 0.04, 0.045, 0.05])  # includes the joints
    sol = simulate("psi3", mforce, (0.0, 0.05), params=params, t_eval=t)
    np.testing.assert_array_equal(sol.t, t)
    assert sol.q.shape == (7, 3) and sol.qd.shape == (7, 3) and sol.y.shape == (2, 7)
    assert sol.segments == [(0.0, 0.01), (0.01, 0.04), (0.04, 0.05)]
    assert sol.nfev > 0 and sol.nsteps > 0


def test_step_outputs_are_increasing_without_duplicates(params, mforce):
    sol = simulate("s", mforce, (0.0, 0.05), params=params, rtol=1e-8)
    assert np.all(np.diff(sol.t) > 0)
    assert sol.t[0] == 0.0 and sol.t[-1] == 0.05
    for joint in (0.01, 0.04):
        assert np.count_nonzero(sol.t == joint) == 1


@pytest.mark.parametrize("method", sorted(SCIPY_METHODS))
def test_every_method_runs_the_manoeuvre(params, mforce, method):
    t = np.linspace(0.0, 0.05, 51)
    sol = simulate("psi3", mforce, (0.0, 0.05), params=params, method=method, rtol=1e-8, t_eval=t)
    assert np.max(np.abs(sol.s - mforce.profile(t)[0])) < 1e-5


@pytest.mark.parametrize("method", ["RK45", "DOP853", "Radau", "BDF"])
def test_projection_holds_constraints_to_rounding_with_each_solver(params, mforce, method):
    sol = simulate("projection", mforce, (0.0, 0.012), params=params, method=method, rtol=1e-6)
    assert sol.residual.max() < 1e-15
    assert sol.velocity_residual.max() < 1e-13


def test_step_force_restarts_at_the_step(params):
    """A step force equals two runs glued at the step time (no stage sees the other value)."""
    q0 = kin.solve_position(S0, params)
    kw = dict(params=params, rtol=1e-12, method="DOP853")
    step = fw.StepForce(300.0, 600.0, 0.004)
    whole = simulate("psi3", step, (0.0, 0.008), initial=(q0, np.zeros(3)), t_eval=[0.008], **kw)
    first = simulate("psi3", 300.0, (0.0, 0.004), initial=(q0, np.zeros(3)), t_eval=[0.004], **kw)
    second = simulate("psi3", 600.0, (0.004, 0.008), y0=first.y[:, -1], t_eval=[0.008], **kw)
    np.testing.assert_allclose(whole.y[:, -1], second.y[:, -1], rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("method", ["DOP853", "dop853-numba"])
def test_unknown_option_is_a_drs_error_naming_it(params, method):
    with pytest.raises(
        DRSError, match=r"unknown option\(s\) \['bogus_option'\] for formulation 'psi3'"
    ):
        simulate("psi3", 0.0, (0.0, 0.01), params=params, method=method, bogus_option=1)
    with pytest.raises(
        DRSError, match=r"unknown option\(s\) \['alfa'\] for formulation 'baumgarte'"
    ):
        simulate("baumgarte", 0.0, (0.0, 0.01), params=params, alfa=10.0)
    with pytest.raises(DRSError, match=r"\['bogus_option'\]"):
        FixedStepIntegrator(params, 1e-3, bogus_option=1)


def test_force_inputs_are_normalised():
    assert isinstance(fw.as_force(3), fw.ConstantForce)
    f = fw.as_force(lambda t: 2.0 * t)
    assert isinstance(f, fw.FunctionForce) and f(1.5) == 3.0
    with pytest.raises(InputError, match="must be a number or a callable"):
        fw.as_force("100 N")
    with pytest.raises(InputError, match="step force t_step must be finite"):
        fw.StepForce(0.0, 1.0, math.inf)


# ---- fixed step -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("method", "dts"),
    [
        ("rk4", (1e-3, 5e-4)),
        ("rk2", (2e-4, 1e-4)),
        ("euler", (1e-4, 5e-5)),
        ("semi-implicit-euler", (1e-4, 5e-5)),
    ],
)
def test_fixed_step_order_against_dop853(params, method, dts):
    """Halving dt divides the error at 10 ms by ~2^order (reference: DOP853 at rtol 1e-13)."""
    ref = _reference(params, np.array([0.01]))
    errors = []
    for dt in dts:
        integ = FixedStepIntegrator(params, dt, method=method)
        integ.reset(s=S0)
        for _ in range(int(round(0.01 / dt))):
            st = integ.step(F_CONST)
        assert st.t == pytest.approx(0.01)
        errors.append(abs(st.psi3 - ref.psi3[-1]))
    order = math.log2(errors[0] / errors[1])
    assert order == pytest.approx(FIXED_STEP_METHODS[method], abs=0.25)


def test_fixed_step_generic_path_matches_fast_kernel(params):
    """The numpy path (any formulation) and the scalar psi3 kernel give the same rk4 steps, up
    to the different coordinates' truncation errors."""
    fast = FixedStepIntegrator(params, 1e-4)
    slow = FixedStepIntegrator(params, 1e-4, formulation="projection")
    fast.reset(s=S0)
    slow.reset(s=S0)
    for _ in range(50):
        a, b = fast.step(F_CONST), slow.step(F_CONST)
    assert a.t == pytest.approx(b.t)
    assert a.s == pytest.approx(b.s, abs=1e-10)
    assert a.psi3 == pytest.approx(b.psi3, abs=1e-9)
    assert a.psi3_dot == pytest.approx(b.psi3_dot, rel=1e-6)


def test_fixed_step_state_is_consistent(params):
    integ = FixedStepIntegrator(params, 1e-4)
    st = integ.reset(s=S0, s_dot=0.3)
    q = kin.solve_position(S0, params)
    qd = kin.velocity_ratio(q, params) * 0.3
    np.testing.assert_allclose([st.s, st.psi1, st.psi3], q, atol=1e-12)
    np.testing.assert_allclose([st.s_dot, st.psi1_dot, st.psi3_dot], qd, rtol=1e-10)
    assert st.gap == pytest.approx(float(kin.gap(q, params)), abs=1e-12)
    assert integ.state is st and integ.t == 0.0
    st2 = integ.reset(psi3=float(q[2]), psi3_dot=float(qd[2]), t=1.0)
    assert st2.s == pytest.approx(S0, abs=1e-12) and st2.s_dot == pytest.approx(0.3, rel=1e-10)
    assert integ.t == 1.0


def test_fixed_step_follows_the_manoeuvre(params, mforce):
    """rk4 at 0.1 ms with the force evaluated at the stages (and its pieces) follows s(t)."""
    integ = FixedStepIntegrator(params, 1e-4)
    err = 0.0
    for _ in range(500):
        st = integ.step(mforce)
        err = max(err, abs(st.s - float(mforce.profile(st.t)[0])))
    assert err < 1e-7


def test_fixed_step_refuses_leaving_the_stroke_and_keeps_state(params, mforce):
    integ = FixedStepIntegrator(params, 1e-4)
    low = 0.8 * mforce(0.0)  # the flap closes further: towards the dead centre
    with pytest.raises(StrokeRangeError, match=r"refused: stroke s = .* leaves \[s_min, s_max\]"):
        for _ in range(1000):
            integ.step(low)
    kept = integ.state
    assert kept.s >= integ.s_min - integ.stroke_margin
    with pytest.raises(StrokeRangeError):
        integ.step(low)
    assert integ.state == kept and integ.t == kept.t


def test_fixed_step_too_large_is_refused_not_nan(params, mforce):
    integ = FixedStepIntegrator(params, 1e-2)
    with pytest.raises((StrokeRangeError, SingularConfigurationError), match="refused"):
        for _ in range(5):
            integ.step(mforce)
    assert all(math.isfinite(v) for v in integ.state)


def test_fixed_step_divergence_is_typed(params, mforce):
    """Explicit rk4 with stiff Baumgarte gains (1e4 1/s) at 1 ms blows up: typed, not NaN."""
    integ = FixedStepIntegrator(params, 1e-3, formulation="baumgarte", alpha=1e4, beta=1e4)
    with pytest.raises(IntegrationError, match=r"diverged|exceeds drift_bound"):
        for _ in range(50):
            integ.step(mforce(0.0))


def test_fixed_step_nan_force(params):
    integ = FixedStepIntegrator(params, 1e-3)
    with pytest.raises(IntegrationError, match="piston force is not finite"):
        integ.step(math.nan)
    assert integ.t == 0.0


def test_fixed_step_arguments(params):
    with pytest.raises(InputError, match="dt must be"):
        FixedStepIntegrator(params, 0.0)
    with pytest.raises(InputError, match="method must be one of"):
        FixedStepIntegrator(params, 1e-3, method="rk5")
    with pytest.raises(InputError, match="stroke_margin must be in"):
        FixedStepIntegrator(params, 1e-3, stroke_margin=0.01)
    integ = FixedStepIntegrator(params, 1e-3)
    with pytest.raises(StrokeRangeError, match="outside"):
        integ.reset(s=0.06)
    with pytest.raises(InputError, match="either s or psi3"):
        integ.reset(s=0.01, psi3=1.0)
    assert issubclass(StrokeRangeError, DRSError)


def test_step_by_and_restore_for_a_search_inside_a_step(params):
    """``step_by(f, h)`` is ``h``-sized :meth:`step` (two halves agree with one whole step to
    RK4's local error, and ``h = dt`` is ``step`` to the bit); ``restore`` goes back to a state
    exactly, so a step taken again from it gives the same bits."""
    whole = FixedStepIntegrator(params, 1e-3)
    whole.reset(s=S0)
    halves = FixedStepIntegrator(params, 1e-3)
    halves.reset(s=S0)
    a = whole.step(F_CONST)
    halves.step_by(F_CONST, 5e-4)
    b = halves.step_by(F_CONST, 5e-4)
    assert b.t == a.t and abs(b.s - a.s) < 1e-9 and b.s != a.s
    start = whole.state
    once = whole.step_by(F_CONST, 1e-3)
    back = whole.restore(start.t, (start.psi3, start.psi3_dot))
    assert back == start
    assert whole.step(F_CONST) == once
    with pytest.raises(InputError, match=r"h must be a finite number in \(0, dt = 0\.001\] s"):
        whole.step_by(F_CONST, 2e-3)
    with pytest.raises(InputError, match="t and y must be finite"):
        whole.restore(0.0, (math.nan, 0.0))
