"""One sample of Newton-Euler (the compiled kernel on floats, every joint reaction) against
independent statements over hypothesis-drawn states: Lagrange's multipliers and force (mass
matrix and constraint Jacobian, no per-body elimination), the seed's nine equations solved as a
generic linear system, and the balance of the whole mechanism with accelerations from
:func:`drs_model.kinematics.point_accelerations`."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from kinematics_support import singular_configurations

from drs_model import inverse as dyn
from drs_model import kinematics as kin
from drs_model.bodies import air_forces
from drs_model.errors import InputError, SingularConfigurationError
from drs_model.kernels import SINGULAR_TOL

#: Agreement of the formulations, relative to the largest force or reaction of the sample [-]
#: (the one used over the manoeuvre in test_inverse.py).
RTOL = 1e-9


def _state(p, fraction: float, sd: float, sdd: float):
    """A consistent state of one sample, shape (3,), at a fraction of the working stroke."""
    s_min, s_max = kin.stroke_limits(p)
    s = s_min + fraction * (s_max - s_min)
    st_ = kin.kinematic_state(np.array([s]), np.array([sd]), np.array([sdd]), p)
    return st_.q[0], st_.qd[0], st_.qdd[0]


def _scale(res) -> float:
    return max(abs(float(res.piston_force)), *(abs(float(v)) for v in res.reactions.values()))


states = given(
    fraction=st.floats(0.0, 1.0),
    sd=st.floats(-8.0, 8.0),  # the seed's opening peaks near 6.8 m/s
    sdd=st.floats(-3e3, 3e3),  # and near 2.1e3 m/s^2
)


@settings(max_examples=60, deadline=None)
@states
def test_one_sample_agrees_with_lagrange(params, fraction, sd, sdd):
    """Force and pin-C reaction of one sample = Lagrange's force and multipliers."""
    state = _state(params, fraction, sd, sdd)
    ne = dyn.inverse_dynamics(state, params, "newton-euler")
    la = dyn.inverse_dynamics(state, params, "lagrange")
    tol = RTOL * _scale(ne)
    assert float(ne.piston_force) == pytest.approx(float(la.piston_force), abs=tol)
    assert float(ne.reactions["rj2x"]) == pytest.approx(float(la.multipliers[0]), abs=tol)
    assert float(ne.reactions["rj2y"]) == pytest.approx(float(la.multipliers[1]), abs=tol)


@settings(max_examples=60, deadline=None)
@states
def test_one_sample_solves_the_seed_equations(params, fraction, sd, sdd):
    """The nine unknowns of one sample solve the seed's nine Newton-Euler equations, solved here
    generically (numpy.linalg.solve, no elimination by hand)."""
    state = _state(params, fraction, sd, sdd)
    ne = dyn.inverse_dynamics(state, params, "newton-euler")
    a, b = dyn.newton_euler_system(state, params)
    x = np.linalg.solve(a, b)
    got = [float(ne.piston_force if k == "F" else ne.reactions[k]) for k in dyn.NE_UNKNOWNS]
    np.testing.assert_allclose(got, x, rtol=0, atol=RTOL * _scale(ne))


@settings(max_examples=60, deadline=None)
@states
def test_one_sample_balances_the_whole_mechanism(params, fraction, sd, sdd):
    """External forces on the three bodies together = sum of m a_G, with the accelerations of the
    kinematics module (the internal pins B and C cancel)."""
    state = _state(params, fraction, sd, sdd)
    r = dyn.inverse_dynamics(state, params, "newton-euler")
    acc = kin.point_accelerations(*state, params, ("G1", "G2", "G3"))
    masses = {"G1": params.m_pist, "G2": params.m_link, "G3": params.m_wing}
    ma = sum(m * acc[k] for k, m in masses.items())
    drag, down = air_forces(state[0][2], params)
    fx = r.reactions["Np"] + r.reactions["rj3x"] + drag
    fy = r.piston_force + r.reactions["rj3y"] - down - params.g * sum(masses.values())
    tol = RTOL * _scale(r)
    assert float(fx) == pytest.approx(float(ma[0]), abs=tol)
    assert float(fy) == pytest.approx(float(ma[1]), abs=tol)


def test_one_sample_equals_the_same_sample_in_a_batch(params):
    """The one-sample path (compiled, floats) and the array path give the same numbers, and the
    one sample keeps the array path's shapes (0-d)."""
    t = np.linspace(0.0, params.T_total, 41)
    _, st_ = dyn.manoeuvre_state(t, params)
    batch = dyn.inverse_dynamics(st_, params, "newton-euler")
    for i in (0, 7, 20, 33):
        one = dyn.inverse_dynamics((st_.q[i], st_.qd[i], st_.qdd[i]), params, "newton-euler")
        assert np.shape(one.piston_force) == ()
        tol = 1e-12 * _scale(one)
        assert float(one.piston_force) == pytest.approx(batch.piston_force[i], abs=tol)
        for name, value in one.reactions.items():
            assert np.shape(value) == ()
            assert float(value) == pytest.approx(batch.reactions[name][i], abs=tol), name


def test_one_sample_refuses_bad_states(params):
    q, qd, qdd = _state(params, 0.5, 1.0, 10.0)
    bad = qd.copy()
    bad[1] = math.nan
    with pytest.raises(InputError, match=r"qd must be finite, got nan"):
        dyn.inverse_dynamics((q, bad, qdd), params, "newton-euler")
    bad = qdd.copy()
    bad[0] = -math.inf
    with pytest.raises(InputError, match=r"qdd must be finite, got -inf"):
        dyn.inverse_dynamics((q, qd, bad), params, "newton-euler")
    dead = singular_configurations(params)[0]
    with pytest.raises(SingularConfigurationError, match=r"dead centre"):
        dyn.inverse_dynamics((dead, qd, qdd), params, "newton-euler")
    with pytest.raises(InputError, match=r"qd must have shape \(\.\.\., 3\).*\(2,\)"):
        dyn.inverse_dynamics((q, qd[:2], qdd), params, "newton-euler")


@pytest.mark.parametrize("offset", [0.0, 5e-10, -5e-10, 2e-9, -2e-9, 1e-3])
def test_one_sample_refuses_the_dead_centre_as_the_batch_does(params, offset):
    """The one-sample validation (floats) refuses exactly the states the batch validation
    (arrays) refuses: around ``psi1 - psi3 = pi/2`` (B, C, D aligned), within and just outside
    the tolerance of the transmission ``|cos(psi1 - psi3)|``."""
    q, qd, qdd = _state(params, 0.5, 1.0, 10.0)
    q = np.array([q[0], q[2] + math.pi / 2 + offset, q[2]])

    def refused(state):
        try:
            dyn.inverse_dynamics(state, params, "newton-euler")
        except SingularConfigurationError as exc:
            assert "dead centre" in str(exc)
            return True
        return False

    one = refused((q, qd, qdd))
    assert one == refused((q[None], qd[None], qdd[None]))
    assert one == (abs(math.cos(q[1] - q[2])) < SINGULAR_TOL)
