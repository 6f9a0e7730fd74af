"""The rigid regressor: ``Y(s, s', s'') theta`` is the inverse dynamics, by every formulation,
for parameters it was not built with; at rest it is the statics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model.errors import InputError
from drs_model.identify.parameters import RIGID_PARAMETERS
from drs_model.identify.regressor import constants_map, rigid_regressor, rigid_values
from drs_model.inverse import INVERSE_METHODS, FusedInverseDynamics, inverse_dynamics
from drs_model.kinematics import kinematic_state
from drs_model.params import DRSParams
from drs_model.profile import drs_manoeuvre


def _manoeuvre(p, n=301):
    man = drs_manoeuvre(p)
    t = np.linspace(0.0, man.t_end, n)
    s, v, a = man.evaluate(t)
    return s, v, a, kinematic_state(s, v, a, p)


@pytest.mark.parametrize("method", sorted(INVERSE_METHODS))
def test_y_theta_is_every_formulation_over_the_manoeuvre(params, method):
    s, v, a, state = _manoeuvre(params)
    force = inverse_dynamics((state.q, state.qd, state.qdd), params, method=method).piston_force
    Y = rigid_regressor(s, v, a, params)
    assert np.max(np.abs(Y @ rigid_values(params) - force)) < 1e-9 * np.max(np.abs(force))


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(0.3, 3.0), min_size=9, max_size=9))
def test_the_regressor_of_one_parameter_set_serves_another(factors):
    """Y depends on the geometry only: built for the seed, it gives the force of masses,
    inertias and air loads scaled by the factors (each to 0.3..3x), as the inverse dynamics
    of those parameters gives it."""
    p0 = DRSParams()
    p1 = p0.replace(
        **{n: f * float(getattr(p0, n)) for n, f in zip(RIGID_PARAMETERS, factors, strict=True)}
    )
    s, v, a, state = _manoeuvre(p0, 101)
    force = inverse_dynamics((state.q, state.qd, state.qdd), p1).piston_force
    got = rigid_regressor(s, v, a, p0) @ rigid_values(p1)
    assert np.max(np.abs(got - force)) < 1e-9 * np.max(np.abs(force))


def test_at_rest_the_regressor_is_the_statics(params):
    from drs_model.kinematics import stroke_limits

    s = np.linspace(*stroke_limits(params), 40)
    Y = rigid_regressor(s, 0.0 * s, 0.0 * s, params)
    static = FusedInverseDynamics.from_params(params)
    expected = np.array([static.force(x, 0.0, 0.0) for x in s])
    assert np.allclose(Y @ rigid_values(params), expected, rtol=1e-12, atol=1e-9)


def test_the_constants_map_is_exact(params):
    """The air law's slopes are differences over the flap's travel: a unit step of the closed
    value moves the slope by 1 / (psi_closed - psi_open), of the open value by minus that."""
    from drs_model.kinematics import flap_angle_limits

    closed, opened = flap_angle_limits(params)
    D = constants_map(params)
    k = 1.0 / (closed - opened)
    i_open, i_closed = (
        RIGID_PARAMETERS.index("F_drag_open"),
        RIGID_PARAMETERS.index("F_drag_closed"),
    )
    assert D[6, i_closed] == pytest.approx(k, rel=1e-9)
    assert D[6, i_open] == pytest.approx(-k, rel=1e-9)
    assert np.allclose(D[:5, :5], np.eye(5))


def test_a_name_outside_the_rigid_parameters_is_refused(params):
    with pytest.raises(InputError, match="'leak_to_outside'.*not rigid parameters.*m_pist"):
        rigid_regressor([0.01], [0.0], [0.0], params, ["m_pist", "leak_to_outside"])
