"""Equation error against output error: where the two stages' values lie farther apart than
their intervals allow, the fit says INCONSISTENT and names the parameters; where the rigid
regression leaves out what it cannot describe, the two agree."""

from __future__ import annotations

import pytest
from identify_support import force_run, noisy_record

from drs_model.fidelity import HydraulicParams
from drs_model.identify.driver import disagreements, fit
from drs_model.identify.identifiability import Identifiability
from drs_model.identify.parameters import with_values
from drs_model.identify.results import Estimate, StageFit


@pytest.fixture(scope="module")
def forced(params):
    return force_run(params)


def _simulate(params):
    def simulate(values):
        p, _ = with_values(values, params, HydraulicParams())
        table = force_run(p)
        return {"stroke": table[:, 1], "piston_force": table[:, 4]}

    return simulate


def _fit(record, params):
    return fit(record, ["m_wing"], "rigid", params, simulate=_simulate(params))


def test_a_regression_that_reads_the_stops_contact_disagrees_and_is_named(forced, params):
    """Told (wrongly) that no stop held the rod, the equation error regresses the contact's
    force as inertia and air load (the acceleration differentiated, exact strokes): its m_wing
    lies far from the output error's, and the fit is inconsistent on m_wing, with both values
    in the note."""
    record = noisy_record(forced, 0.0, 1, stops_hold=False, stroke_acceleration=True)
    result = _fit(record, params)
    assert result.inconsistent == ("m_wing",)
    (note,) = [n for n in result.notes if n.startswith("INCONSISTENT")]
    assert "m_wing: equation error" in note and "output error" in note
    # started from the equation error's value, the output error ends in another minimum: the
    # verdict is the warning that neither can be bet on


def test_stages_that_model_the_same_samples_agree(forced, params):
    record = noisy_record(forced, 0.0, 1, stops_hold=True, stroke_acceleration=True)
    result = _fit(record, params)
    assert result.inconsistent == ()
    eq, oe = (s.estimates[0] for s in result.stages)
    assert eq.contains(params.m_wing) and oe.contains(params.m_wing)


def _stage(stage, value, lower, upper):
    e = Estimate("m_wing", "kg", value, lower, upper, (upper - lower) / 3.92, 2.0, stage)
    ident = Identifiability(("m_wing",), 1, 1.0, (), ("m_wing",), {}, ())
    return StageFit(stage, stage, (e,), ident)


@pytest.mark.parametrize(
    ("out", "split"),
    [
        ((2.2, 2.1, 2.3), False),  # 0.2 apart; allowed hypot(0.2, 0.1) = 0.224
        ((2.35, 2.25, 2.45), True),  # 0.35 apart; allowed 0.224
        ((1.75, 1.7, 1.8), True),  # 0.25 apart; allowed hypot(0.1, 0.05) = 0.112
        ((2.6, 1.6, 2.7), False),  # 0.6 apart; allowed hypot(0.2, 1.0) = 1.02
    ],
)
def test_the_distance_allowed_is_both_half_intervals_facing_each_other(out, split):
    """Equation error 2.0 in [1.9, 2.2] (asymmetric): apart by more than sqrt(a^2 + b^2), ``a``
    and ``b`` the halves facing each other, is inconsistent."""
    stages = [_stage("equation", 2.0, 1.9, 2.2), _stage("output", *out)]
    assert ("m_wing" in disagreements(stages)) == split


def test_a_residual_no_stroke_noise_explains_gives_no_equation_error_value(forced, params):
    """With 10 um of noise and the contact regressed, the noise correction would exceed the
    information (a negative variance): the equation error gives no value, saying why, and the
    output error's stands alone."""
    record = noisy_record(forced, 1e-5, 1, stops_hold=False)
    result = _fit(record, params)
    eq = result.stages[0].estimates[0]
    assert not eq.determined and "more than the stroke's noise explains" in eq.reason
    assert result.inconsistent == () and result.estimate("m_wing").contains(params.m_wing)
