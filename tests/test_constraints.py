"""Constraint residual, Jacobian, gamma and determinants against independent derivations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model.constraints import (
    constraint,
    constraint_gamma,
    constraint_jacobian,
    dependent_determinant,
    jacobian_blocks,
    partition,
    singularity_measure,
)
from drs_model.errors import InputError
from drs_model.kinematics import point_positions

coords = st.tuples(st.floats(-0.05, 0.3), st.floats(-np.pi, np.pi), st.floats(-np.pi, np.pi)).map(
    np.array
)


def test_seed_printed_residual(params):
    """The seed's printed s = 0 solutions violate its own Phi by ~5e-7 m (10-digit output)."""
    for q in ([0.0, -0.1824644031, 1.093620968], [0.0, -0.5760483505, 1.289458931]):
        res = np.abs(constraint(np.array(q), params))
        assert 1e-8 < res.max() < 1e-6


@given(coords)
@settings(max_examples=60, deadline=None)
def test_constraint_is_c3_minus_c(params, q):
    pts = point_positions(q, params, ("C", "C3"))
    np.testing.assert_allclose(constraint(q, params), pts["C3"] - pts["C"], atol=1e-15)


@given(coords)
@settings(max_examples=60, deadline=None)
def test_jacobian_against_central_differences(params, q):
    h = 1e-6
    fd = np.stack(
        [
            (constraint(q + h * e, params) - constraint(q - h * e, params)) / (2 * h)
            for e in np.eye(3)
        ],
        axis=-1,
    )
    np.testing.assert_allclose(constraint_jacobian(q, params), fd, atol=1e-9)


@given(
    coords,
    st.tuples(*[st.floats(-50, 50)] * 3).map(np.array),
    st.tuples(*[st.floats(-1e3, 1e3)] * 3).map(np.array),
)
@settings(max_examples=60, deadline=None)
def test_gamma_is_minus_the_convective_term(params, q, qd, qdd):
    """Along q(t) = q + qd t + qdd t^2/2: d^2 Phi/dt^2 at 0 = Phi_q qdd - gamma (2nd difference)."""
    h = 1e-5
    path = [constraint(q + qd * t + 0.5 * qdd * t * t, params) for t in (-h, 0.0, h)]
    second = (path[0] - 2 * path[1] + path[2]) / h**2
    expected = constraint_jacobian(q, params) @ qdd - constraint_gamma(q, qd, params)
    np.testing.assert_allclose(second, expected, atol=1e-4 * (1 + np.abs(expected).max()))


@given(coords)
@settings(max_examples=40, deadline=None)
def test_dependent_determinants(params, q):
    for name in ("s", "psi3"):
        _, jd = jacobian_blocks(q, params, name)
        assert dependent_determinant(q, params, name) == pytest.approx(np.linalg.det(jd), abs=1e-15)
        assert 0.0 <= singularity_measure(q, params, name) <= 1.0 + 1e-15


def test_vectorised_shapes(params):
    q = np.zeros((4, 5, 3))
    assert constraint(q, params).shape == (4, 5, 2)
    assert constraint_jacobian(q, params).shape == (4, 5, 2, 3)
    ji, jd = jacobian_blocks(q, params)
    assert ji.shape == (4, 5, 2, 1) and jd.shape == (4, 5, 2, 2)


def test_bad_partition():
    with pytest.raises(InputError, match=r"independent coordinate must be one of \['psi3', 's'\]"):
        partition("psi1")


@given(coords)
@settings(max_examples=40, deadline=None)
def test_one_sample_of_floats_is_the_array_formula(params, q):
    """A tuple of three floats (the one-sample path, ``math``) gives a float equal to the
    determinant of the Jacobian block (numpy's ``det``) and to the array path."""
    one = tuple(q.tolist())
    for name in ("s", "psi3"):
        _, jd = jacobian_blocks(q, params, name)
        det = dependent_determinant(one, params, name)
        assert type(det) is float
        assert det == pytest.approx(np.linalg.det(jd), abs=1e-15)
        measure = singularity_measure(one, params, name)
        assert type(measure) is float
        assert measure == pytest.approx(float(singularity_measure(q, params, name)), abs=1e-15)
