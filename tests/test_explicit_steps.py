"""The explicit fixed steps (drs_model.explicit_steps): each method is its Butcher tableau, and the
three users (the real-time step of formulation (a), the integrator's numpy formulations, the
hydraulic rung's RK4) run that one step, to the bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drs_model.compiled.scalar import compiled_or_plain
from drs_model.explicit_steps import FIXED_STEP_METHODS, STEPS
from drs_model.fidelity import hydraulic_steps as hs
from drs_model.fidelity import make_rung
from drs_model.forward import FixedStepIntegrator
from drs_model.forward.formulations import Psi3Minimal

#: The classic tableaux (A, b, c) of the explicit methods, independent of the module's code.
TABLEAUX = {
    "euler": ([[0.0]], [1.0], [0.0]),
    "rk2": ([[0.0, 0.0], [0.5, 0.0]], [0.0, 1.0], [0.0, 0.5]),
    "rk4": (
        [[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1.0, 0]],
        [1 / 6, 1 / 3, 1 / 3, 1 / 6],
        [0.0, 0.5, 0.5, 1.0],
    ),
}


def _pendulum(t, y):
    """A forced damped pendulum ``y = [x, v]``, ``x' = v``: a right-hand side of time and state."""
    return np.array([y[1], -9.0 * math.sin(y[0]) - 0.3 * y[1] + 2.0 * math.cos(5.0 * t)])


def _rate_of_time(out, y, t, fun):
    out[:] = fun(t, y)


def _tableau_step(tableau, fun, t, y, h):
    a, b, c = (np.asarray(v, dtype=float) for v in tableau)
    k = []
    for i in range(len(b)):
        k.append(fun(t + c[i] * h, y + h * sum(a[i, j] * k[j] for j in range(i))))
    return y + h * sum(b[i] * k[i] for i in range(len(b)))


@pytest.mark.parametrize("method", sorted(TABLEAUX))
def test_each_method_is_its_butcher_tableau(method):
    """Over 200 steps of a forced pendulum, each step equals the tableau's general formula (a
    different order of operations: equal to rounding, 1e-13), and the steps differ from one
    another by far more (a wrong weight or stage time would show)."""
    rng = np.random.default_rng(3)
    states, times = rng.uniform(-2, 2, (200, 2)), rng.uniform(0, 1, 200)
    for y, t, h in zip(states, times, rng.uniform(1e-4, 0.05, 200), strict=True):
        got = STEPS[method](_rate_of_time, y, h, t, t + 0.5 * h, t + h, _pendulum)
        ref = _tableau_step(TABLEAUX[method], _pendulum, t, y, h)
        np.testing.assert_allclose(got, ref, rtol=1e-13, atol=1e-13)
    y, t, h = np.array([1.0, -0.5]), 0.2, 0.05
    others = [_tableau_step(tab, _pendulum, t, y, h) for m, tab in TABLEAUX.items() if m != method]
    got = STEPS[method](_rate_of_time, y, h, t, t + 0.5 * h, t + h, _pendulum)
    assert all(np.max(np.abs(got - o)) > 1e-6 for o in others)


def test_semi_implicit_euler_updates_the_rate_first():
    """Semi-implicit Euler: ``v1 = v0 + h a(x0, v0)``, then ``x1 = x0 + h v1`` (not ``v0``)."""
    y, t, h = np.array([1.0, -0.5]), 0.2, 0.05
    got = STEPS["semi-implicit-euler"](_rate_of_time, y, h, t, t + 0.5 * h, t + h, _pendulum)
    v1 = y[1] + h * _pendulum(t, y)[1]
    assert got[1] == v1 and got[0] == y[0] + h * v1
    assert abs(got[0] - (y[0] + h * y[1])) > 1e-4  # explicit Euler's position differs


@pytest.mark.parametrize("method", sorted(FIXED_STEP_METHODS))
def test_the_real_time_step_is_the_shared_step_on_the_numpy_rhs(params, method):
    """The compiled step of formulation (a) that the integrator (and the rigid rung under a force)
    runs equals, to the bit, the shared step run as plain Python on the psi3 formulation's numpy
    right-hand side with the force taken at each stage's time (as the integrator's path for the
    other formulations runs it): one step, two callers. A step rewritten for two floats in another
    order of operations, or a stage taken at the wrong time, fails here."""
    integ = FixedStepIntegrator(params, 1e-4, method)
    compiled_step = integ._psi3_step  # what FixedStepIntegrator.step calls for formulation (a)
    form = Psi3Minimal(params)
    rng = np.random.default_rng(11)
    for b, bd, f0, f1, f2, h in rng.uniform(
        [0.6, -100.0, -3e3, -3e3, -3e3, 1e-6], [1.5, 100.0, 2e4, 2e4, 2e4, 1e-3], (300, 6)
    ):
        t = 0.25
        forces = {t: f0, t + 0.5 * h: f1, t + h: f2}
        fun = form.fun(forces.__getitem__)
        shared = STEPS[method](_rate_of_time, np.array([b, bd]), h, t, t + 0.5 * h, t + h, fun)
        got = compiled_step(b, bd, f0, f1, f2, h)
        assert np.array_equal(np.array(got), shared, equal_nan=True), (b, bd, f0, f1, f2, h)


def test_the_hydraulic_rk4_is_the_shared_step(params):
    """The hydraulic rung's compiled RK4 (what the rung runs) equals, to the bit, the shared RK4
    run as plain Python on the plain right-hand side ``state_rate``, with the references at the
    step's start, middle and end and the middle's supply pressure the mean of the ends'."""
    rung = make_rung("hydraulic", params, 1e-3)
    rung.reset(s=0.01)
    c, h = rung._consts
    built = compiled_or_plain(hs.rk4_step, hs.CALLEES)

    def rate(out, y, refs, args):
        (s_ref, v_ref, ps), (mode, f_ref, held) = refs, args
        out[:] = hs.state_rate(y, mode, s_ref, v_ref, f_ref, ps, held, tuple(c), tuple(h))

    rng = np.random.default_rng(5)
    y0 = rung.y
    for _ in range(50):
        y = y0 * rng.uniform(0.95, 1.05, 5)
        y[1], y[4] = rng.uniform(-3.0, 3.0), rng.uniform(-0.5, 0.5)
        s0, v0, sm, vm, s1, v1 = rng.uniform(0.0, 0.02, 6)
        ps0, ps1, dt, f_ref = 210e5, rng.uniform(150e5, 210e5), 1e-5, rng.uniform(-100, 100)
        got = built(y, 0.0, s0, v0, sm, vm, s1, v1, f_ref, ps0, ps1, 0.0, dt, c, h)
        middle = (sm, vm, 0.5 * (ps0 + ps1))
        shared = STEPS["rk4"](rate, y, dt, (s0, v0, ps0), middle, (s1, v1, ps1), (0.0, f_ref, 0.0))
        assert np.array_equal(got, shared)
        assert np.max(np.abs(got - y)) > 0.0
