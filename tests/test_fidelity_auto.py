"""``fidelity: auto``'s rule (drs_model.fidelity.auto) against a measurement the test makes:
``drs fidelity`` run now on the rule's scene gives each rung's errors; the rule must choose, for
every question and tolerance, the first rung in the ladder's order whose errors meet it. No
number here is written down: a model change that moves the errors moves the expectations."""

from __future__ import annotations

import json
import math
from itertools import chain, combinations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_model.cli import build_parser
from drs_model.cli._common import dumps
from drs_model.errors import InputError
from drs_model.fidelity.auto import (
    ASKED,
    AUTO_DT,
    AUTO_SCENE,
    RungErrors,
    choose_rung,
    ladder_errors,
)
from drs_model.params import DRSParams

#: The ladder's order, as the rule states it.
ORDER = ("kinematic", "quasi-static", "rigid", "hydraulic")
QUESTIONS = [set(c) for c in chain.from_iterable(combinations(ASKED, k) for k in range(4))]


@pytest.fixture(scope="module")
def measured() -> dict[str, tuple[float, float | None]]:
    """rung -> (gap error [m], force error [N] or None), from ``drs fidelity --scene
    open-hold-close-100ms --json`` (the rule's scene and step), run now."""
    args = build_parser().parse_args(
        ["fidelity", "--scene", AUTO_SCENE, "--dt", str(AUTO_DT), "--json"]
    )
    rows = json.loads(dumps(args.func(args).data))["rows"]  # as printed: NaN is null
    out = {r["run"]: (r["errors"]["gap"], r["errors"]["force"]) for r in rows if r["run"] in ORDER}
    assert set(out) == set(ORDER)
    return out


def _expected(asked, gap_tol, force_tol, measured) -> str:
    """The rule, stated on its own: the first rung in the ladder's order that has what is asked
    within the tolerances, else the reference."""
    for rung in ORDER:
        gap, force = measured[rung]
        if "hydraulics" in asked and rung != "hydraulic":
            continue
        if "gap" in asked and gap > gap_tol:
            continue
        if "force" in asked and (force is None or force > force_tol):
            continue
        return rung
    return "hydraulic"


def test_the_run_time_table_is_the_fresh_measurement(measured):
    table = ladder_errors()
    for rung in ORDER:
        gap, force = measured[rung]
        assert table[rung].gap == pytest.approx(gap, rel=1e-12)
        if force is None:
            assert table[rung].force is None
        else:
            assert table[rung].force == pytest.approx(force, rel=1e-12)


def test_the_rule_meets_the_measured_errors_on_each_side_of_each(measured):
    """Tolerances just below and just above every measured error (and far on either side), for
    every question: the rule's choice is the first rung in the ladder's order that meets them."""
    table = ladder_errors()
    gaps = sorted({g for g, _ in measured.values()})
    forces = sorted({f for _, f in measured.values() if f is not None})
    gap_tols = [1e-12, 1.0] + [g * k for g in gaps for k in (0.999, 1.001)]
    force_tols = [1e-3, 1e6] + [f * k for f in forces for k in (0.999, 1.001)]
    chosen = set()
    for asked in QUESTIONS:
        for gap_tol in gap_tols:
            for force_tol in force_tols:
                rung = choose_rung(asked, gap_tol, force_tol, table)
                assert rung == _expected(asked, gap_tol, force_tol, measured), (
                    asked,
                    gap_tol,
                    force_tol,
                )
                chosen.add(rung)
    assert {"kinematic", "hydraulic"} <= chosen and len(chosen) >= 3  # the grid's answers vary


@settings(deadline=None, max_examples=200)
@given(
    asked=st.sets(st.sampled_from(ASKED)),
    gap_tol=st.floats(1e-8, 1.0),
    force_tol=st.floats(1e-3, 1e5),
)
def test_the_choice_meets_the_tolerances_and_no_lower_rung_does(asked, gap_tol, force_tol):
    table = ladder_errors()

    def meets(rung):
        e = table[rung]
        has_force = e.force is not None and e.force <= force_tol
        return (
            ("hydraulics" not in asked or rung == "hydraulic")
            and ("gap" not in asked or e.gap <= gap_tol)
            and ("force" not in asked or has_force)
        )

    chosen = choose_rung(asked, gap_tol, force_tol, table)
    assert meets(chosen) or chosen == "hydraulic"
    assert not any(meets(r) for r in ORDER[: ORDER.index(chosen)])


def test_ties_go_down_the_ladder_never_to_a_timing():
    """Two rungs with the same errors: the lower one, whatever they cost (the table holds no
    cost); a lower rung that meets the tolerances wins over a more accurate higher one."""
    same = RungErrors(2e-4, 1.0e3)
    table = {
        "kinematic": RungErrors(2e-4, None),
        "quasi-static": same,
        "rigid": same,
        "hydraulic": RungErrors(1e-7, 5.0),
    }
    assert choose_rung({"gap", "force"}, 5e-4, 2e3, table) == "quasi-static"
    table["rigid"] = RungErrors(1e-4, 10.0)  # more accurate, and still not chosen
    assert choose_rung({"gap", "force"}, 5e-4, 2e3, table) == "quasi-static"
    assert choose_rung({"gap", "force"}, 5e-4, 500.0, table) == "rigid"
    assert choose_rung({"gap"}, 5e-4, 2e3, table) == "kinematic"
    assert choose_rung(set(), 5e-4, 2e3, table) == "kinematic"
    assert choose_rung({"hydraulics"}, 1.0, 1e6, table) == "hydraulic"
    assert set(vars(same)) == {"gap", "force"}


def test_the_table_follows_the_model():
    """A flap four times as heavy: the statics miss more inertial force, so the quasi-static
    rung's measured force error grows, and a tolerance between the two errors changes the
    choice. A table written down once could not see this."""
    light, heavy = ladder_errors(), ladder_errors(DRSParams(m_wing=4.0 * DRSParams().m_wing))
    assert heavy["quasi-static"].force > 1.2 * light["quasi-static"].force
    between = math.sqrt(light["quasi-static"].force * heavy["quasi-static"].force)
    assert choose_rung({"force"}, 1.0, between, light) == "quasi-static"
    assert choose_rung({"force"}, 1.0, between, heavy) != "quasi-static"


def test_bad_input_is_refused():
    table = ladder_errors()
    with pytest.raises(InputError, match="asked must be among"):
        choose_rung({"torque"}, 5e-4, 2e3, table)
    with pytest.raises(InputError, match="gap_tolerance must be a finite number > 0"):
        choose_rung({"gap"}, 0.0, 2e3, table)
