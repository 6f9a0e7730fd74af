"""DRSParams: seed defaults, derived values, overrides and validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drs_model import DRSParams, ParameterError, from_dict, from_file
from drs_model.params import SEED_LITERAL_IZ_WING


def test_seed_defaults_are_the_worksheet_data(params):
    # seed 003 "Data": a few values spelled out again here, from the worksheet text
    assert (params.x_A, params.y_A, params.x_D, params.y_D) == (0.28, 0.0, 0.335, 0.154)
    assert (params.L1, params.L2, params.L3, params.L_wing) == (0.016, 0.05, 0.1, 0.12)
    assert (params.x_R, params.y_R, params.d_wing, params.d_tip) == (0.28, 0.0223, 0.006, 0.01)
    assert params.gamma == pytest.approx(5 * math.pi / 180, rel=1e-15)
    assert (params.m_pist, params.m_link, params.m_wing) == (0.08, 0.0375, 2.0)
    assert params.m_link == pytest.approx(0.05 * 0.75, rel=1e-15)  # L2 of a 0.75 kg/m steel bar
    assert (params.box_width, params.box_height) == (0.35, 0.22)
    assert (params.gap_closed, params.gap_open) == (0.01, 0.05)
    assert params.T_total == pytest.approx(0.05, rel=1e-15)  # seed: T_tot := 0.0500
    assert len(params.flap_outline) == 43 and len(params.main_wing_outline) == 43


def test_inertia_defaults():
    p = DRSParams()
    assert p.Iz_link == pytest.approx(0.0375 * 0.05**2 / 12, rel=1e-15)
    assert p.Iz_wing == pytest.approx(2.0 * 0.12**2 / 3, rel=1e-15)
    assert DRSParams(Iz_wing=SEED_LITERAL_IZ_WING).Iz_wing == pytest.approx(0.08, rel=1e-15)


def test_flap_com_matches_seed_moment_arms(params):
    """G3 is the mean of the flap outline; the seed's flap Euler equation (eqns_NE_static[9])
    prints the arms of rj3 about G3: 0.05085213524 and 0.02850866573 at psi3 = 1.087076363."""
    from drs_model.kinematics import point_positions

    q = np.array([0.0001989391299, -0.1706738276, 1.087076363])
    g3 = point_positions(q, params, ("G3",))["G3"]
    assert params.x_D - g3[0] == pytest.approx(0.02850866573, abs=1e-11)
    assert params.y_D - g3[1] == pytest.approx(0.05085213524, abs=1e-11)


def test_direct_construction_checks_the_geometry():
    with pytest.raises(ParameterError, match=r"unreachable geometry"):
        DRSParams(L3=0.03)


def test_bad_outlines_and_mappings(tmp_path):
    with pytest.raises(ParameterError, match=r"flap_outline must have shape \(n >= 3, 2\)"):
        DRSParams(flap_outline=((0.0, 0.0), (1.0, 1.0)))
    with pytest.raises(ParameterError, match=r"main_wing_outline holds a non-finite coordinate"):
        DRSParams(main_wing_outline=((0.0, 0.0), (1.0, float("nan")), (2.0, 0.0)))
    with pytest.raises(ParameterError, match=r"parameter overrides must be a mapping, got list"):
        from_dict([("L1", 0.01)])
    from ros_support import require_module

    require_module("yaml")
    f = tmp_path / "list.yaml"
    f.write_text("- 1\n- 2\n")
    with pytest.raises(ParameterError, match=r"must hold a table of name = value"):
        from_file(f)


def test_overrides_and_replace():
    p = from_dict({"m_wing": 3.0})
    assert p.m_wing == 3.0 and p.Iz_wing == pytest.approx(3.0 * 0.12**2 / 3)
    assert DRSParams().replace(L1=0.02).L1 == 0.02


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"L2": 0.0}, r"L2 must be > 0 m, got 0\.0"),
        ({"L3": -0.1}, r"L3 must be > 0 m, got -0\.1"),
        ({"m_wing": float("nan")}, r"m_wing must be finite, got nan"),
        ({"g": "9.81"}, r"g must be a real number, got '9\.81'"),
        ({"gap_closed": 0.06}, r"gap_closed < gap_open"),
        ({"d_tip": 0.2}, r"d_tip must be < L_wing"),
        ({"T_still": -1.0}, r"T_still must be >= 0"),
        ({"bogus": 1.0}, r"unknown parameter\(s\) \['bogus'\]"),
        ({"L3": 0.03}, r"unreachable geometry"),
        ({"gap_open": 0.3}, r"unreachable geometry: gap 0\.3 m is unreachable"),
    ],
)
def test_bad_values_are_refused(overrides, match):
    with pytest.raises(ParameterError, match=match):
        from_dict(overrides)


def test_from_toml_and_yaml(tmp_path):
    from ros_support import require_module

    toml = tmp_path / "p.toml"
    toml.write_text("[drs]\nm_wing = 2.5\nIz_wing = 0.08\n")
    assert from_file(toml).m_wing == 2.5
    require_module("yaml")
    yml = tmp_path / "p.yaml"
    yml.write_text("m_pist: 0.1\n")
    assert from_file(yml).m_pist == 0.1


def test_bad_files(tmp_path):
    with pytest.raises(ParameterError, match=r"cannot read parameter file"):
        from_file(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("m_wing = = 2")
    with pytest.raises(ParameterError, match=r"cannot parse parameter file"):
        from_file(bad)
    txt = tmp_path / "p.txt"
    txt.write_text("")
    with pytest.raises(ParameterError, match=r"must end in \.toml, \.yaml or \.yml"):
        from_file(txt)


def test_frozen(params):
    with pytest.raises(AttributeError):
        params.L1 = 1.0  # type: ignore[misc]


def test_package_exports_resolve():
    """Every name in drs_model.__all__ resolves (the heavy ones lazily), and an unknown one raises
    AttributeError with its name."""
    import drs_model

    for name in drs_model.__all__:
        assert getattr(drs_model, name) is not None, name
    with pytest.raises(AttributeError, match=r"has no attribute 'nope'"):
        drs_model.nope  # noqa: B018


def test_yaml_without_pyyaml_says_what_to_install(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "yaml", None)  # as if pyyaml were not installed
    f = tmp_path / "p.yaml"
    f.write_text("m_pist: 0.1\n")
    with pytest.raises(ParameterError, match=r"needs pyyaml .*a \.toml file needs nothing extra"):
        from_file(f)
