"""``fidelity: auto``'s rule (drs_model.fidelity.auto): the cheapest rung whose measured error
meets the tolerances for what is asked, from the ladder's committed measurements."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from drs_model.errors import InputError
from drs_model.fidelity.auto import ASKED, LADDER_ERRORS, choose_rung

RESULTS = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "fidelity.json"


def test_the_table_is_the_ladders_measurement():
    """The rule's errors and costs are those ``drs fidelity --json`` wrote for the 100 ms
    manoeuvre (rounded to 2-3 digits)."""
    rows = {r["run"]: r for r in json.loads(RESULTS.read_text())["rows"]
            if r["scene"] == "open-hold-close-100ms"}  # fmt: skip
    for rung, (gap, force, cost) in LADDER_ERRORS.items():
        row = rows[rung]
        assert gap == pytest.approx(row["errors"]["gap"], rel=0.01)
        if force is None:
            assert row["errors"]["force"] is None
        else:
            assert force == pytest.approx(row["errors"]["force"], rel=0.01)
        assert cost == pytest.approx(row["cost_per_simulated_second"], rel=0.02)


@pytest.mark.parametrize(
    ("asked", "force_tol", "rung"),
    [
        (set(), 2e3, "kinematic"),
        ({"gap"}, 2e3, "kinematic"),
        ({"gap", "force"}, 2e3, "rigid"),  # rigid is cheaper than quasi-static, measured
        ({"force"}, 1.35e3, "quasi-static"),  # only quasi-static's 1.32 kN is within 1.35 kN
        ({"force"}, 100.0, "hydraulic"),  # the chart's 100 N: nothing but the cylinder
        ({"gap", "hydraulics"}, 2e3, "hydraulic"),
    ],
)
def test_examples(asked, force_tol, rung):
    assert choose_rung(asked, 5e-4, force_tol) == rung


@given(
    asked=st.sets(st.sampled_from(ASKED)),
    gap_tol=st.floats(1e-8, 1.0),
    force_tol=st.floats(1e-3, 1e5),
)
def test_the_choice_meets_the_tolerances_and_nothing_cheaper_does(asked, gap_tol, force_tol):
    chosen = choose_rung(asked, gap_tol, force_tol)

    def meets(rung):
        gap, force, _ = LADDER_ERRORS[rung]
        return (
            ("hydraulics" not in asked or rung == "hydraulic")
            and ("gap" not in asked or gap <= gap_tol)
            and ("force" not in asked or (force is not None and force <= force_tol))
        )

    cost = LADDER_ERRORS[chosen][2]
    assert meets(chosen) or chosen == "hydraulic"
    assert not any(meets(r) for r in LADDER_ERRORS if LADDER_ERRORS[r][2] < cost)


def test_bad_input_is_refused():
    with pytest.raises(InputError, match="asked must be among"):
        choose_rung({"torque"}, 5e-4, 2e3)
    with pytest.raises(InputError, match="gap_tolerance must be a finite number > 0"):
        choose_rung({"gap"}, 0.0, 2e3)
