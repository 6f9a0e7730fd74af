"""What differs between the rungs is a property of the rung, not a question the node asks of its
type: ``has_fluid``, ``method_options`` and ``check_stiffness``; a method option a rung does not
use is refused for it, not ignored."""

from __future__ import annotations

import pytest

from drs_model.errors import InputError
from drs_model.explicit_steps import FIXED_STEP_METHODS
from drs_model.fidelity import RUNGS, make_rung
from drs_model.params import DRSParams

P = DRSParams()


@pytest.mark.parametrize("rung", list(RUNGS))
def test_a_method_option_is_taken_where_the_rung_uses_it_and_refused_elsewhere(rung):
    cls = RUNGS[rung]
    for option, other in (("integrator", "euler"), ("force_method", "newton-euler")):
        if option in cls.method_options:
            sim = make_rung(rung, P, 1e-3, **{option: other})
            sim.advance(3)  # it runs with it
        else:
            with pytest.raises(InputError, match=f"the {rung} rung does not use {option}"):
                make_rung(rung, P, 1e-3, **{option: other})
        make_rung(rung, P, 1e-3, **{option: {"integrator": "rk4", "force_method": "fused"}[option]})


def test_the_rigid_rung_uses_both_and_an_unknown_value_is_still_an_error():
    assert RUNGS["rigid"].method_options == {"integrator", "force_method"}
    assert "euler" in FIXED_STEP_METHODS
    with pytest.raises(InputError):
        make_rung("rigid", P, 1e-3, integrator="no-such-method")
    with pytest.raises(InputError):  # unknown is refused before unused
        make_rung("kinematic", P, 1e-3, integrator="no-such-method")


def test_only_the_hydraulic_rung_has_fluid_and_measures_its_stiffness():
    assert [r for r, cls in RUNGS.items() if cls.has_fluid] == ["hydraulic"]
    for rung in ("kinematic", "quasi-static", "rigid"):
        assert make_rung(rung, P, 1e-3).check_stiffness() == 1
    hydraulic = make_rung("hydraulic", P, 1e-3)
    assert hydraulic.check_stiffness() > 1  # the chambers need sub-steps of a 1 ms step
    hydraulic.advance(2)
    state = hydraulic.state
    assert state.pressure_a is not None and state.pressure_b is not None


def test_the_node_asks_no_rung_its_type():
    """No module of the node names a rung's class (what differs is the rung's property)."""
    from pathlib import Path

    node = Path(__file__).resolve().parents[1] / "drs_ros" / "node"
    hits = [
        f"{p.name}: {line.strip()}"
        for p in sorted(node.glob("*.py"))
        for line in p.read_text().splitlines()
        if any(
            name in line
            for name in ("HydraulicRung", "KinematicRung", "QuasiStaticRung", "RigidRung")
        )
    ]
    assert hits == []
