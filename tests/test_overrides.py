"""Overrides by name (drs_model.overrides): DRSParams and HydraulicParams names, bare or as the
node names them, applied to each; the valve's port ratio follows the bore and rod as a derived
inertia follows its mass; the ``drs`` subcommands that run the hydraulic rung take them, the
others refuse them."""

from __future__ import annotations

import json
import math

import pytest

from drs_model.cli import main
from drs_model.errors import ParameterError
from drs_model.fidelity import HydraulicParams
from drs_model.fidelity.hydraulic_params import hydraulic_from_dict
from drs_model.overrides import apply_overrides, assignment_overrides, split_overrides
from drs_model.params import DRSParams


def test_names_are_sorted_into_the_model_s_and_the_hydraulic_ones():
    model, hydraulic = split_overrides(
        {
            "m_wing": 3.0,
            "model.L2": 0.05,
            "hydraulic.leak_to_outside": 1e-12,
            "coulomb_friction": 50.0,
        }
    )
    assert model == {"m_wing": 3.0, "L2": 0.05}
    assert hydraulic == {"leak_to_outside": 1e-12, "coulomb_friction": 50.0}
    p, hp = apply_overrides({"m_wing": 3.0, "hydraulic.leak_to_outside": 1e-12})
    assert p.m_wing == 3.0 and p.Iz_wing == pytest.approx(3.0 * 0.12**2 / 3.0, rel=1e-15)
    assert hp == HydraulicParams(leak_to_outside=1e-12)
    with pytest.raises(ParameterError, match=r"unknown parameter\(s\) \['leak_to_outsid'\]"):
        apply_overrides({"leak_to_outsid": 1.0})
    with pytest.raises(ParameterError, match=r"bulk_modulus must be > 0"):
        apply_overrides({"bulk_modulus": -1.0})


def test_flow_law_is_the_one_word_of_set():
    assert assignment_overrides(["flow_law=linear", "bulk_modulus=1e9"]) == {
        "flow_law": "linear",
        "bulk_modulus": 1e9,
    }
    assert apply_overrides(assignment_overrides(["flow_law=linear"]))[1].flow_law == "linear"


def test_the_port_ratio_recorded_as_the_area_ratio_follows_the_bore_and_rod():
    """A recorded run records the ratio it ran (the area ratio, 3/4 for 16 and 8 mm); read back
    and re-run with another rod, the ratio is that rod's area ratio, not the old number."""
    recorded = hydraulic_from_dict({"valve_port_ratio": 0.75})
    assert recorded == HydraulicParams()  # the same as never given
    thinner = hydraulic_from_dict({"rod_diameter": 0.006}, base=recorded)
    assert thinner.port_ratio == pytest.approx((0.016**2 - 0.006**2) / 0.016**2, rel=1e-14)
    given = hydraulic_from_dict({"valve_port_ratio": 0.5})
    assert hydraulic_from_dict({"rod_diameter": 0.006}, base=given).port_ratio == 0.5


def test_a_command_without_a_hydraulic_rung_refuses_hydraulic_values(capsys):
    assert main(["kinematics", "--stroke", "0.02", "--set", "leak_to_outside=1e-12"]) == 2
    assert "leak_to_outside" in capsys.readouterr().err


def test_drs_fidelity_runs_the_hydraulic_values_given(monkeypatch, tmp_path, capsys):
    """``drs fidelity --set`` and ``--params`` reach the ladder's hydraulic rung."""
    import drs_model.cli.fidelity as fidelity_cli

    seen = {}

    def measure(p, dt, **kwargs):
        seen.update(p=p, hydraulic=kwargs["hydraulic"])
        return []

    monkeypatch.setattr(fidelity_cli, "measure", measure)
    path = tmp_path / "car.toml"
    path.write_text("m_wing = 2.5\nviscous_friction = 300.0\n")
    main(["fidelity", "--json", "--params", str(path), "--set", "bulk_modulus=1e9"])
    capsys.readouterr()
    assert seen["p"] == DRSParams(m_wing=2.5)
    assert seen["hydraulic"] == HydraulicParams(bulk_modulus=1e9, viscous_friction=300.0)


def test_drs_excite_designs_for_the_hydraulic_values_given(capsys):
    """A valve four times slower (its spool's time constant) changes what the design predicts."""

    def predicted(*extra):
        # the seed manoeuvre's prediction does not depend on the design: one short start
        assert (
            main(
                [
                    "excite",
                    "m_pist",
                    "--fidelity",
                    "hydraulic",
                    "--json",
                    "--starts",
                    "1",
                    "--harmonics",
                    "2",
                    *extra,
                ]
            )
            == 0
        )
        (row,) = json.loads(capsys.readouterr().out)["parameters"]
        return row["std_seed_manoeuvre"]

    default, slow = predicted(), predicted("--set", "spool_time_constant=3.2e-3")
    assert math.isfinite(default) and math.isfinite(slow) and slow != default
