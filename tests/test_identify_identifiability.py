"""Identifiability: rank, condition number, what cannot be separated and why, measured on
sensitivity matrices whose answer is known by construction, and on the rigid regressor, whose
null space follows from the mechanism (the link's mass is two point masses at its pins)."""

from __future__ import annotations

import numpy as np
import pytest

from drs_model.errors import InputError
from drs_model.identify.identifiability import assess, too_wide
from drs_model.identify.parameters import RIGID_PARAMETERS
from drs_model.identify.regressor import rigid_regressor
from drs_model.profile import drs_manoeuvre


def test_a_full_rank_matrix_determines_everything():
    rng = np.random.default_rng(0)
    J = rng.normal(size=(40, 3)) * [1e13, 1.0, 1e-9]  # columns in any unit
    ident = assess(J, ["a", "b", "c"], [1e-13, 1.0, 1e9])
    assert ident.rank == 3 and ident.determined == ("a", "b", "c") and not ident.undetermined
    assert np.isfinite(ident.condition_number) and ident.condition_number < 100


def test_a_repeated_column_is_a_pair_that_cannot_be_separated():
    rng = np.random.default_rng(1)
    J = rng.normal(size=(30, 3))
    J[:, 2] = -2.0 * J[:, 0]  # c trades against a
    ident = assess(J, ["a", "b", "c"], [1.0, 1.0, 1.0])
    assert ident.rank == 2 and ident.condition_number > 1e12
    (gone,) = ident.undetermined
    other = ({"a", "c"} - {gone}).pop()
    assert f"cannot separate it from {other}" in ident.undetermined[gone]
    assert ident.groups == (("a", "c"),)


def test_a_zero_column_is_in_no_equation():
    J = np.column_stack([np.arange(10.0), np.zeros(10)])
    ident = assess(J, ["a", "b"], [1.0, 1.0])
    assert ident.determined == ("a",)
    assert "zero sensitivity" in ident.undetermined["b"]


def test_nearly_collinear_columns_are_reported_as_trading_off():
    rng = np.random.default_rng(2)
    x = rng.normal(size=50)
    J = np.column_stack([x, x + 1e-3 * rng.normal(size=50), rng.normal(size=50)])
    ident = assess(J, ["a", "b", "c"], [1.0, 1.0, 1.0])
    assert ident.rank == 3
    (pair,) = ident.pairs
    assert pair[:2] == ("a", "b") and abs(pair[2]) > 0.999


def test_the_rigid_parameters_have_two_null_directions(params):
    """Nine rigid parameters, seven base parameters: the link's mass acts as two point masses
    at its pins (one riding with the piston, one turning with the flap), and the flap's weight
    acts as a constant downforce: m_link and one of the flap's inertial parameters cannot be
    separated from the others, on any motion."""
    man = drs_manoeuvre(params)
    t = np.linspace(0.0, man.t_end, 200)
    scales = [max(abs(float(getattr(params, n))), 1e-9) for n in RIGID_PARAMETERS]
    ident = assess(rigid_regressor(*man.evaluate(t), params), RIGID_PARAMETERS, scales)
    assert ident.rank == 7
    assert len(ident.undetermined) == 2
    members = {m for g in ident.groups for m in g}
    assert members == {"m_pist", "m_link", "m_wing", "Iz_link", "Iz_wing"}


def test_bad_shapes_are_refused():
    with pytest.raises(InputError, match=r"J must be \(n, 2\)"):
        assess(np.ones((5, 3)), ["a", "b"], [1.0, 1.0])
    with pytest.raises(InputError, match="non-finite"):
        assess(np.array([[np.nan], [1.0]]), ["a"], [1.0])


@pytest.mark.parametrize(
    ("value", "half", "scale", "wide"),
    [
        (2.0, 1.0, 1.0, False),
        (2.0, 2.5, 1.0, True),
        (0.0, 5e-14, 1e-13, False),
        (0.0, 2e-13, 1e-13, True),
        (9e20, 5e20, 60.0, True),  # within itself, but 1e19 times its typical size wide
        (5e4, 5.9e4, 60.0, True),
        (5e4, 5e4, 60.0, True),
        (5e4, 5.9e3, 60.0, False),  # a value far from its default, known to 12 %
    ],
)
def test_an_interval_wider_than_the_value_is_no_determination(value, half, scale, wide):
    """Wider than the value itself, or than a thousand typical sizes: a column of near-zeros
    (no slow motion for the breakaway friction) gives a huge value with a huge interval that
    is "within itself" and says nothing."""
    assert too_wide(value, half, scale) is wide
